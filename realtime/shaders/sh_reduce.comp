#version 430
// SH9 projection, pass 2: sum the workgroup partials into the 9 RGB coefficients and build the
// paper's irradiance matrices M (eq. 12), one 4x4 per colour channel.
layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;
layout(std430, binding = 1) readonly buffer Partials { vec4 partial[]; };
layout(std430, binding = 2) writeonly buffer SH { mat4 M[3]; vec4 coeffs[9]; };
uniform int n_groups;
uniform float window[3];  // per-band SH window (1, 1, 1 = none)

shared vec3 acc[64][9];

void main() {
    uint lid = gl_LocalInvocationIndex;
    vec3 c[9];
    for (int k = 0; k < 9; ++k) c[k] = vec3(0.0);
    for (int g = int(lid); g < n_groups; g += 64)
        for (int k = 0; k < 9; ++k) c[k] += partial[g * 9 + k].rgb;
    for (int k = 0; k < 9; ++k) acc[lid][k] = c[k];
    barrier();
    for (uint stride = 32u; stride > 0u; stride >>= 1u) {
        if (lid < stride)
            for (int k = 0; k < 9; ++k) acc[lid][k] += acc[lid + stride][k];
        barrier();
    }
    if (lid != 0u) return;
    vec3 L[9];
    for (int k = 0; k < 9; ++k) {
        int band = k == 0 ? 0 : (k < 4 ? 1 : 2);
        L[k] = acc[0][k] * window[band];
        coeffs[k] = vec4(L[k], 0.0);
    }
    // c1..c5 of eq. 12 (c5 = c3 / 3, not the paper's misprint), #defined by the host from realtime/engine/sh.py
    const float c1 = SH_M1, c2 = SH_M2, c3 = SH_M3, c4 = SH_M4, c5 = SH_M5;
    for (int ch = 0; ch < 3; ++ch) {
        float L00 = L[0][ch], L1m1 = L[1][ch], L10 = L[2][ch], L11 = L[3][ch];
        float L2m2 = L[4][ch], L2m1 = L[5][ch], L20 = L[6][ch], L21 = L[7][ch], L22 = L[8][ch];
        // symmetric, so column-major storage reads the same as rows
        M[ch] = mat4(c1 * L22,  c1 * L2m2, c1 * L21,  c2 * L11,
                     c1 * L2m2, -c1 * L22, c1 * L2m1, c2 * L1m1,
                     c1 * L21,  c1 * L2m1, c3 * L20,  c2 * L10,
                     c2 * L11,  c2 * L1m1, c2 * L10,  c4 * L00 - c5 * L20);
    }
}
