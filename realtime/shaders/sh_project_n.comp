#version 430
// SH projection of any order (SH_ORDER 2..8, SH_COUNT = (SH_ORDER + 1)^2 coefficients; defines from
// scenes.shbasis.glsl_defines), pass 1. Modelled on sh_project.comp (the paper's SH9, which stays as
// it is): every texel of the selected level adds L(w) Y_k(w) dOmega(w). Each invocation sums a block
// of block x block texels in registers, then the 8x8 workgroup reduces (sh_workgroup_sum.glsl, in chunks of shared memory) and writes
// SH_COUNT RGB partial sums. dOmega comes from a texture of exact texel solid angles (float64 numpy).
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;  // 64 invocations (sh_workgroup_sum.glsl)
layout(rgba32f, binding = 0) uniform readonly imageCube level;
uniform sampler2D solid_angle;  // (size x size), R channel
uniform int size;
uniform int block;  // texels per invocation along each axis
layout(std430, binding = 1) writeonly buffer Partials { vec4 partial[]; };  // SH_COUNT per workgroup
#include "common.glsl"
#include "sh_basis.glsl"
#include "sh_workgroup_sum.glsl"

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    uint lid = gl_LocalInvocationIndex;
    vec3 c[SH_COUNT];
    for (int k = 0; k < SH_COUNT; ++k) c[k] = vec3(0.0);
    float y[SH_COUNT];
    for (int by = 0; by < block; ++by) {
        for (int bx = 0; bx < block; ++bx) {
            ivec3 t = ivec3(g.x * block + bx, g.y * block + by, g.z);
            if (t.x >= size || t.y >= size) continue;
            float sc = 2.0 * (float(t.x) + 0.5) / float(size) - 1.0;
            float tc = 2.0 * (float(t.y) + 0.5) / float(size) - 1.0;
            vec3 d = normalize(face_direction(t.z, sc, tc));
            vec3 L = imageLoad(level, t).rgb * texelFetch(solid_angle, t.xy, 0).r;
            sh_eval(d, y);
            for (int k = 0; k < SH_COUNT; ++k) c[k] += L * y[k];
        }
    }
    sh_workgroup_sum(lid, c);
    if (lid == 0u) {
        uint group = gl_WorkGroupID.x + gl_NumWorkGroups.x * (gl_WorkGroupID.y + gl_NumWorkGroups.y * gl_WorkGroupID.z);
        for (int k = 0; k < SH_COUNT; ++k) partial[group * uint(SH_COUNT) + uint(k)] = vec4(c[k], 0.0);
    }
}
