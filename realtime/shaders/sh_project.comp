#version 430
// SH9 projection, pass 1: every texel of the selected level adds L(w) Y_lm(w) dOmega(w). Each
// invocation sums a block of block x block texels in registers, then the 8x8 workgroup reduces in
// shared memory and writes 9 RGB partial sums (fewer barrier phases: they are costly on llvmpipe).
// The basis constants SH_C0..SH_C4 are #defined by the host from scenes/environment/shbasis.py.
// dOmega comes from a texture of exact texel solid angles (computed in float64 by numpy: the
// atan2 corner formula loses precision in float32 on fine faces).
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;  // 64 x 9 x vec3 fits 32 KiB shared
layout(rgba32f, binding = 0) uniform readonly imageCube level;
uniform sampler2D solid_angle;  // (size x size), R channel
uniform int size;
uniform int block;  // texels per invocation along each axis
layout(std430, binding = 1) writeonly buffer Partials { vec4 partial[]; };  // 9 per workgroup
#include "common.glsl"

shared vec3 acc[64][9];

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    uint lid = gl_LocalInvocationIndex;
    vec3 c[9];
    for (int k = 0; k < 9; ++k) c[k] = vec3(0.0);
    for (int by = 0; by < block; ++by) {
        for (int bx = 0; bx < block; ++bx) {
            ivec3 t = ivec3(g.x * block + bx, g.y * block + by, g.z);
            if (t.x >= size || t.y >= size) continue;
            float sc = 2.0 * (float(t.x) + 0.5) / float(size) - 1.0;
            float tc = 2.0 * (float(t.y) + 0.5) / float(size) - 1.0;
            vec3 d = normalize(face_direction(t.z, sc, tc));
            vec3 L = imageLoad(level, t).rgb * texelFetch(solid_angle, t.xy, 0).r;
            float x = d.x, y = d.y, z = d.z;
            c[0] += L * SH_C0;
            c[1] += L * (SH_C1 * y);
            c[2] += L * (SH_C1 * z);
            c[3] += L * (SH_C1 * x);
            c[4] += L * (SH_C2 * x * y);
            c[5] += L * (SH_C2 * y * z);
            c[6] += L * (SH_C3 * (3.0 * z * z - 1.0));
            c[7] += L * (SH_C2 * x * z);
            c[8] += L * (SH_C4 * (x * x - y * y));
        }
    }
    for (int k = 0; k < 9; ++k) acc[lid][k] = c[k];
    barrier();
    for (uint stride = 32u; stride > 0u; stride >>= 1u) {
        if (lid < stride)
            for (int k = 0; k < 9; ++k) acc[lid][k] += acc[lid + stride][k];
        barrier();
    }
    if (lid == 0u) {
        uint group = gl_WorkGroupID.x + gl_NumWorkGroups.x * (gl_WorkGroupID.y + gl_NumWorkGroups.y * gl_WorkGroupID.z);
        for (int k = 0; k < 9; ++k) partial[group * 9u + uint(k)] = vec4(acc[0][k], 0.0);
    }
}
