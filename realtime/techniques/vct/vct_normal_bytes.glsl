// How a face normal is stored (realtime/techniques/vct/vct.py: RGBA8 textures, vct.VoxelScene.write_level0 and
// read_normals use the same bytes): a component n as the byte 128 + 127 n, so that n = 0 is exact, and "no
// surface faces this face" as the normal 0 (bytes 128). The decoding is affine in the stored value, so a
// blend of stored values (a mip-linear read) decodes to the same blend of the normals.
// Alpha holds how far the surfaces' unit normals spread about that mean: their mean cosine l about it (the
// mean's length at level 0; 1 for one plane, less where the normals turn: vct_normals.comp, vct_normal_mip.comp)
// as sqrt(1 - l), whose steps are finest near l = 1, where a sharp glossy lobe needs them (the smallest nonzero
// 1 - l is 1.5e-5; vct_trace.glsl's vct_gloss_radiance reads it). A blend of two stored values is a blend of
// sqrt(1 - l), not of l.
vec4 vct_normal_encoded(vec3 n, float mean_length) {
    return vec4((128.0 + 127.0 * n) / 255.0, sqrt(clamp(1.0 - mean_length, 0.0, 1.0)));
}

float vct_normal_mean_length(vec4 stored) {
    return 1.0 - stored.a * stored.a;
}

vec3 vct_normal_decoded(vec4 stored) {
    return (255.0 * stored.rgb - 128.0) / 127.0;
}
