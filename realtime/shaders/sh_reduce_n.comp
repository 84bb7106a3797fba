#version 430
// SH projection of any order (SH_ORDER 2..8), pass 2: sum the workgroup partials into the SH_COUNT
// RGB coefficients, window them per band, and write the reconstruction weights
// weighted_k = A_l sigma_l L_k (A_l: R&H 2001 clamped-cosine factors, SH_A<l>; sigma_l: `window`), so
// that shading computes E(n) = sum_k weighted_k Y_k(n) with one sh_eval (sh_basis.glsl).
layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;
layout(std430, binding = 1) readonly buffer Partials { vec4 partial[]; };
layout(std430, binding = 2) writeonly buffer SH { vec4 coeffs[SH_COUNT]; vec4 weighted[SH_COUNT]; };
uniform int n_groups;
uniform float window[SH_ORDER + 1];  // per-band SH window (all 1 = none)
#include "sh_basis.glsl"
#include "sh_workgroup_sum.glsl"

void main() {
    uint lid = gl_LocalInvocationIndex;
    vec3 c[SH_COUNT];
    for (int k = 0; k < SH_COUNT; ++k) c[k] = vec3(0.0);
    for (int g = int(lid); g < n_groups; g += 64)
        for (int k = 0; k < SH_COUNT; ++k) c[k] += partial[g * SH_COUNT + k].rgb;
    sh_workgroup_sum(lid, c);
    if (lid != 0u) return;
    for (int l = 0; l <= SH_ORDER; ++l) {
        for (int k = l * l; k < (l + 1) * (l + 1); ++k) {
            vec3 L = c[k] * window[l];
            coeffs[k] = vec4(L, 0.0);
            weighted[k] = vec4(SH_COSINE_BAND[l] * L, 0.0);
        }
    }
}
