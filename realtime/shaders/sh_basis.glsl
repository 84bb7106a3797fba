// Real SH basis of bands 0..SH_ORDER (2..8) at a unit world direction; mirrors
// scenes/environment/shbasis.py (sh_basis) exactly: coefficient k = l^2 + l + m, the "z-up" functions on world
// (x, y, z), no Condon-Shortley phase. Every constant comes from the host as a #define
// (scenes.shbasis.glsl_defines(order)): SH_ORDER, SH_COUNT, SH_C0..SH_C4 (bands 0-2, the paper's
// literals), SH_K3m / SH_K4m (bands 3, 4), for bands 5..SH_ORDER the table SH_POLY (per (l, m), m = 0..l,
// the z^2-coefficients of N_lm P_l^(m)(z): shbasis.GENERIC_POLYNOMIALS) and the clamped-cosine factors
// SH_A0..SH_A<order>. Bands 0-2 are computed as sh_project.comp computes them.
#if !defined(SH_ORDER) || !defined(SH_COUNT)
#error "sh_basis.glsl needs SH_ORDER and SH_COUNT (scenes.shbasis.glsl_defines)"
#endif
#if SH_ORDER < 2 || SH_ORDER > 8 || SH_COUNT != (SH_ORDER + 1) * (SH_ORDER + 1)
#error "sh_basis.glsl supports SH_ORDER 2..8 with SH_COUNT = (SH_ORDER + 1)^2"
#endif
#if SH_ORDER >= 5 && !defined(SH_POLY)
#error "sh_basis.glsl needs SH_POLY for SH_ORDER >= 5 (scenes.shbasis.glsl_defines)"
#endif

// R&H 2001 clamped-cosine factors A_l per band: E(n) = sum_k A_l(k) L_k Y_k(n)
const float SH_COSINE_BAND[SH_ORDER + 1] = float[](
    SH_A0, SH_A1, SH_A2
#if SH_ORDER >= 3
    , SH_A3
#endif
#if SH_ORDER >= 4
    , SH_A4
#endif
#if SH_ORDER >= 5
    , SH_A5
#endif
#if SH_ORDER >= 6
    , SH_A6
#endif
#if SH_ORDER >= 7
    , SH_A7
#endif
#if SH_ORDER >= 8
    , SH_A8
#endif
);

#if SH_ORDER >= 5
const float SH_POLY_TABLE[] = SH_POLY;
#endif

void sh_eval(vec3 d, out float y[SH_COUNT]) {
    float x = d.x, yy = d.y, z = d.z;
    y[0] = SH_C0;
    y[1] = SH_C1 * yy;
    y[2] = SH_C1 * z;
    y[3] = SH_C1 * x;
    y[4] = SH_C2 * x * yy;
    y[5] = SH_C2 * yy * z;
    y[6] = SH_C3 * (3.0 * z * z - 1.0);
    y[7] = SH_C2 * x * z;
    y[8] = SH_C4 * (x * x - yy * yy);
#if SH_ORDER >= 3
    float z2 = z * z;
    float re2 = x * x - yy * yy, im2 = 2.0 * x * yy;          // (x + iy)^2
    float re3 = x * (x * x - 3.0 * yy * yy), im3 = yy * (3.0 * x * x - yy * yy);  // (x + iy)^3
    float a31 = SH_K31 * (5.0 * z2 - 1.0);
    y[9] = SH_K33 * im3;
    y[10] = SH_K32 * z * im2;
    y[11] = a31 * yy;
    y[12] = SH_K30 * z * (5.0 * z2 - 3.0);
    y[13] = a31 * x;
    y[14] = SH_K32 * z * re2;
    y[15] = SH_K33 * re3;
#endif
#if SH_ORDER >= 4
    float a41 = SH_K41 * z * (7.0 * z2 - 3.0);
    float a42 = SH_K42 * (7.0 * z2 - 1.0);
    float re4 = re2 * re2 - im2 * im2, im4 = 2.0 * re2 * im2;  // (x + iy)^4
    y[16] = SH_K44 * im4;
    y[17] = SH_K43 * z * im3;
    y[18] = a42 * im2;
    y[19] = a41 * yy;
    y[20] = SH_K40 * ((35.0 * z2 - 30.0) * z2 + 3.0);
    y[21] = a41 * x;
    y[22] = a42 * re2;
    y[23] = SH_K43 * z * re3;
    y[24] = SH_K44 * re4;
#endif
#if SH_ORDER >= 5
    // bands 5..SH_ORDER: Horner in z^2 over SH_POLY, times z when l - m is odd, times Re / Im (x + iy)^m
    float re[SH_ORDER + 1], im[SH_ORDER + 1];
    re[0] = 1.0;
    im[0] = 0.0;
    for (int m = 1; m <= SH_ORDER; ++m) {
        re[m] = re[m - 1] * x - im[m - 1] * yy;
        im[m] = re[m - 1] * yy + im[m - 1] * x;
    }
    int p = 0;
    for (int l = 5; l <= SH_ORDER; ++l) {
        int k = l * l + l;
        for (int m = 0; m <= l; ++m) {
            int n = (l - m) / 2 + 1;
            float q = 0.0;
            for (int j = n - 1; j >= 0; --j) q = q * z2 + SH_POLY_TABLE[p + j];
            p += n;
            if (((l - m) & 1) == 1) q *= z;
            if (m == 0) {
                y[k] = q;
            } else {
                y[k + m] = q * re[m];
                y[k - m] = q * im[m];
            }
        }
    }
#endif
}
