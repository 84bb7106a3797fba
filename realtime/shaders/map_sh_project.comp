#version 430
// SH projection of one level of a 2D parameterization (realtime/engine/environment_maps.py), pass 1, any
// order (SH_ORDER 2..8 from scenes.shbasis.glsl_defines): every texel adds L(w) Y_k(w) dOmega(w),
// with its world direction w and its exact solid angle (zero outside the disc) from texel_dir,
// computed in float64 by numpy (scenes/environment/paraboloid.py, scenes/environment/spheremap.py). Blocks of
// block x block texels per invocation, an 8x8 workgroup reduction, SH_COUNT partial sums per group:
// the layout sh_reduce.comp (order 2, the paper's M) and sh_reduce_n.comp read.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 0) uniform readonly image2DArray level;
uniform sampler2D texel_dir;  // (size, layers size): xyz world direction, w solid angle
uniform int size;
uniform int block;
layout(std430, binding = 1) writeonly buffer Partials { vec4 partial[]; };
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
            vec4 dw = texelFetch(texel_dir, ivec2(t.x, t.y + t.z * size), 0);
            if (dw.w <= 0.0) continue;  // outside the disc
            vec3 L = imageLoad(level, t).rgb * dw.w;
            sh_eval(dw.xyz, y);
            for (int k = 0; k < SH_COUNT; ++k) c[k] += L * y[k];
        }
    }
    sh_workgroup_sum(lid, c);
    if (lid == 0u) {
        uint group = gl_WorkGroupID.x + gl_NumWorkGroups.x * (gl_WorkGroupID.y + gl_NumWorkGroups.y * gl_WorkGroupID.z);
        for (int k = 0; k < SH_COUNT; ++k) partial[group * uint(SH_COUNT) + uint(k)] = vec4(c[k], 0.0);
    }
}
