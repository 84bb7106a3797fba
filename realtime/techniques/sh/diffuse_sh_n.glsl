#ifdef DIFFUSE_SH_N
// SH irradiance of order SH_ORDER (3 or 4): E(n) = sum_k w_k Y_k(n) with w_k = A_l sigma_l L_k
// written by sh_reduce_n.comp (realtime/techniques/sh/diffuse_sh.py, realtime/engine/sh_orders.py).
#include "sh_basis.glsl"
layout(std430, binding = 2) readonly buffer SHN { vec4 coeffs[SH_COUNT]; vec4 weighted[SH_COUNT]; };

vec3 diffuse_irradiance(vec3 n) {
    float y[SH_COUNT];
    sh_eval(n, y);
    vec3 E = vec3(0.0);
    for (int k = 0; k < SH_COUNT; ++k) E += weighted[k].rgb * y[k];
    return E;
}
#endif
