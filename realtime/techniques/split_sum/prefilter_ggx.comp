#version 430
// One level of the split sum's GGX-prefiltered chain (realtime/techniques/split_sum/samples.py): each texel,
// direction n, gets the n = v = r GGX lobe's weighted mean of the source,
//     P(n) = sum L(l) n.l / sum n.l   over the level's samples with n.l > 0,
// whose half vectors were drawn with density D(h) n.h. The sample set is computed once on the host in
// float64, all levels' rows in one buffer (this level's are first .. first + count - 1):
//   xyz = the direction l in the frame z = n, as (l.x, l.y, 1 - l.z) [n.l = 1 - z keeps a lobe of alpha
//         2e-3 in float32],
//   w   = 0.5 log2(Omega_s / Omega_p), filtered importance sampling's source level (Krivanek & Colbert
//         2008) before the recipe's bias and the clamp to the source's levels.
// The frame about n is Duff et al. 2017 ("Building an orthonormal basis, revisited"), robust for all n.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 1) uniform writeonly imageCube dst;
layout(std430, binding = 6) readonly buffer Samples { vec4 lobe_sample[]; };
uniform samplerCube source;  // the environment cube with its mip chain (trilinear)
uniform int size;            // face size of the level written
uniform int first;           // the level's first row in lobe_sample
uniform int count;           // its number of rows
uniform float bias;          // LOD bias added to every sample's level; very negative = every sample reads level 0
uniform float max_lod;       // log2(source base size)
#include "common.glsl"

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (g.x >= size || g.y >= size) return;
    float sc = 2.0 * (float(g.x) + 0.5) / float(size) - 1.0;
    float tc = 2.0 * (float(g.y) + 0.5) / float(size) - 1.0;
    vec3 n = normalize(face_direction(g.z, sc, tc));
    float sgn = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sgn + n.z);
    float b = n.x * n.y * a;
    vec3 t1 = vec3(1.0 + sgn * n.x * n.x * a, sgn * b, -sgn * n.x);
    vec3 t2 = vec3(b, sgn + n.y * n.y * a, -n.y);
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    for (int k = first; k < first + count; ++k) {
        vec4 s = lobe_sample[k];
        float n_dot_l = 1.0 - s.z;
        vec3 l = s.x * t1 + s.y * t2 + n_dot_l * n;
        sum += textureLod(source, l, clamp(s.w + bias, 0.0, max_lod)).rgb * n_dot_l;
        weight += n_dot_l;
    }
    // the set always holds h = n (the Hammersley point v = 0), so weight > 0; the guard keeps an empty set finite
    vec3 value = weight > 0.0 ? sum / weight : textureLod(source, n, 0.0).rgb;
    imageStore(dst, g, vec4(value, 1.0));
}
