#version 430
// One level of one face texture's anisotropic mip (realtime/techniques/vct/vct.py; vct_math.anisotropic_mip): for
// face direction s e_a, the 2x2x2 children pair up along axis a, the child on the s side in front:
// c = c_front + (1 - a_front) c_back (front to back, premultiplied); the four pairs are averaged.
// Cascades are stacked along z, each R_L deep at level L: children never cross a cascade.
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(rgba16f, binding = 0) uniform readonly image3D src;
layout(rgba16f, binding = 1) uniform writeonly image3D dst;
uniform ivec3 dst_size;
uniform int axis;   // 0, 1, 2
uniform int sign_;  // +1 or -1

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(g, dst_size))) return;
    ivec3 s = 2 * g;
    ivec3 e = ivec3(0);
    e[axis] = 1;
    ivec3 u = ivec3(0), w = ivec3(0);
    u[(axis + 1) % 3] = 1;
    w[(axis + 2) % 3] = 1;
    vec4 sum = vec4(0.0);
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
            ivec3 p = s + i * u + j * w;
            vec4 lo = imageLoad(src, p), hi = imageLoad(src, p + e);
            vec4 front = sign_ > 0 ? hi : lo;
            vec4 back = sign_ > 0 ? lo : hi;
            sum += front + (1.0 - front.a) * back;
        }
    imageStore(dst, g, 0.25 * sum);
}
