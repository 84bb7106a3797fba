#ifdef DIFFUSE_SH9
// The paper's SH9 irradiance: E(n) = n^T M n per channel (Ramamoorthi & Hanrahan 2001, eq. 12),
// M written by sh_reduce.comp (realtime/techniques/sh/diffuse_sh.py).
layout(std430, binding = 2) readonly buffer SH { mat4 M[3]; vec4 coeffs[9]; };

vec3 diffuse_irradiance(vec3 n) {
    vec4 n4 = vec4(n, 1.0);
    return vec3(dot(n4, M[0] * n4), dot(n4, M[1] * n4), dot(n4, M[2] * n4));
}
#endif
