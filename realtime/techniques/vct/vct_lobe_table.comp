#version 430
// The environment convolved with normalised Phong lobes of broad exponents (lobe_table.py's LobeTable), one
// layer per exponent N_j = 2^j - 1, each layer an equirect grid of lobe axes r:
//     L_g(r, N) = sum_k L_k W_k (r . d_k)^N / sum_k W_k (r . d_k)^N   over the texels k with r . d_k > 0,
// the quadrature over a level of the environment's chain weighted by solid angle (its rgb / a the texel's mean
// radiance L_k, W_k its exact solid angle, d_k its centre's direction). Normalising by the discrete sum keeps a
// constant environment's value exact; the integral it stands for is (N + 1) / (2 pi) int L(w) (r . w)^N dw
// over the hemisphere about r.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 0) uniform readonly imageCube src;      // the weighted chain's level for this layer
layout(rgba32f, binding = 1) uniform writeonly image3D table;     // (width, height, layers)
layout(std430, binding = 0) readonly buffer Texels { vec4 texels[]; };  // the level's (direction, solid angle)
uniform int src_size;
uniform int layer;
uniform float exponent;  // the layer's Phong exponent (lobe_table.layer_exponents)
uniform ivec2 table_size;
#include "vct_lobe_axis.glsl"

void main() {
    ivec2 g = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(g, table_size))) return;
    vec3 r = vct_lobe_axis((vec2(g) + 0.5) / vec2(table_size));
    float N = exponent;
    vec3 sum = vec3(0.0);
    float norm = 0.0;
    int n = src_size * src_size;
    for (int face = 0; face < 6; ++face) {
        for (int k = 0; k < n; ++k) {
            vec4 t = texels[face * n + k];
            float c = dot(r, t.xyz);
            if (c <= 0.0) continue;
            float w = t.w * pow(c, N);
            vec4 L = imageLoad(src, ivec3(k % src_size, k / src_size, face));
            sum += w * L.rgb / max(L.a, 1e-30);
            norm += w;
        }
    }
    imageStore(table, ivec3(g, layer), vec4(sum / max(norm, 1e-30), 1.0));
}
