#version 430
// Irradiance map, pass 2 (realtime/techniques/irradiance_map/irradiance_convolution.py): for every output texel direction n,
//     E(n) = sum_texels L(w) max(n.w, 0) dOmega(w)
// over every texel of the source level (packed by irradiance_pack.comp); with NORMALIZE divided by
// the discrete kernel mass: E = pi sum(L c dOmega) / sum(c dOmega), c = max(n.w, 0).
//
// Speed on llvmpipe (a workgroup runs on one core, invocations in 8-wide SIMD):
// - each invocation accumulates B output texels of one row, so one load of a source texel feeds
//   B outputs (the loads, not the arithmetic, bound the one-output version);
// - each output also gives its antipode -n for the price of a max and 4 FMAs: c = n.w is computed
//   once and max(-c, 0) weighs the antipode. Only faces +X, +Y, +Z are dispatched; by the face
//   table the antipode of texel (i, j) is (i, s-1-j) on -X and -Z and (s-1-i, j) on -Y.
//   (E(-n) = E(n) - n.M with the first moment M would save the 4 FMAs, but loses E(-n) to float32
//   cancellation opposite a 1e6 sun: 100 % error there.)
// Defines from the host: B, LX, LY (local size LX x LY, B texels per invocation along x), NORMALIZE.
layout(local_size_x = LX, local_size_y = LY, local_size_z = 1) in;
layout(rgba32f, binding = 1) uniform writeonly imageCube irradiance;
layout(std430, binding = 4) readonly buffer Packed { vec4 packed_texels[]; };  // (w dOmega, dOmega), (L, 1)
uniform int size;      // output face size
uniform int n_texels;  // 6 source_size^2
#include "common.glsl"

vec3 normalized(vec4 e) {
#ifdef NORMALIZE
    return e.rgb * (PI / max(e.a, 1e-30));
#else
    return e.rgb;
#endif
}

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    int face = 2 * g.z;  // +X, +Y, +Z
    vec3 n[B];
    vec4 acc[B];   // about n:  rgb = sum L c dOmega, a = sum c dOmega
    vec4 anti[B];  // about -n
    for (int b = 0; b < B; ++b) {
        float sc = 2.0 * (float(g.x * B + b) + 0.5) / float(size) - 1.0;
        float tc = 2.0 * (float(g.y) + 0.5) / float(size) - 1.0;
        n[b] = normalize(face_direction(face, sc, tc));
        acc[b] = vec4(0.0);
        anti[b] = vec4(0.0);
    }
    for (int k = 0; k < n_texels; ++k) {
        vec3 w = packed_texels[2 * k].xyz;
        vec4 L = packed_texels[2 * k + 1];
        for (int b = 0; b < B; ++b) {
            float c = dot(n[b], w);
            acc[b] += max(c, 0.0) * L;
            anti[b] += max(-c, 0.0) * L;
        }
    }
    // Keep this loop simple: NIR must unroll it, or n[], acc[], anti[] become indexed memory and
    // the main loop runs 3x slower on llvmpipe.
    int y_anti = face == 2 ? g.y : size - 1 - g.y;
    for (int b = 0; b < B; ++b) {
        int x = g.x * B + b;
        vec3 e = normalized(acc[b]);
        vec3 e_anti = normalized(anti[b]);
        if (x < size && g.y < size) {
            imageStore(irradiance, ivec3(x, g.y, face), vec4(e, 1.0));
            imageStore(irradiance, ivec3(face == 2 ? size - 1 - x : x, y_anti, face + 1), vec4(e_anti, 1.0));
        }
    }
}
