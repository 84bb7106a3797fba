// How a face normal is stored (realtime/techniques/vct/vct.py: RGBA8 textures, vct.VoxelScene.write_level0 and
// read_normals use the same bytes): a component n as the byte 128 + 127 n, so that n = 0 is exact, and "no
// surface faces this face" as the normal 0 (bytes 128). The decoding is affine in the stored value, so a
// blend of stored values (a mip-linear read) decodes to the same blend of the normals; alpha is unused.
vec4 vct_normal_encoded(vec3 n) {
    return vec4((128.0 + 127.0 * n) / 255.0, 0.0);
}

vec3 vct_normal_decoded(vec4 stored) {
    return (255.0 * stored.rgb - 128.0) / 127.0;
}
