#version 430
// One level of the Phong-prefiltered cube map (realtime/techniques/prefiltered/prefilter.py): each texel, direction r, gets
//     G(r) = int L(l) (N + 1) / (2 pi) max(r.l, 0)^N dl
// estimated by importance sampling the normalised lobe itself, so every sample has weight
// f / pdf = 1 and G is the mean of the samples (the horizon cut is ignored, as in the paper's chain).
// The sample set (a Hammersley set warped to the lobe) is computed once on the host in float64:
//   xyz = the direction in the lobe frame, (sin a cos phi, sin a sin phi, 1 - cos a)  [z is 1 - cos a:
//         for N = 1e6, a ~ 1e-3 and cos a itself would round away the lobe's shape],
//   w   = 0.5 log2(Omega_s / Omega_p), the filtered-importance-sampling LOD (Krivanek & Colbert 2008):
//         Omega_s = 1 / (samples pdf(l)) is the solid angle a sample stands for, Omega_p = 4 pi / (6 base^2)
//         a base texel's; the sample reads the source's mip level of that footprint (+ bias).
// The frame about r is Duff et al. 2017 ("Building an orthonormal basis, revisited"), robust for all r.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 1) uniform writeonly imageCube dst;
layout(std430, binding = 6) readonly buffer Samples { vec4 lobe_sample[]; };
uniform samplerCube source;  // the environment cube with its mip chain (trilinear, seamless)
uniform int size;            // face size of the level written
uniform int samples;
uniform float bias;          // LOD bias; very negative = no filtering (every sample reads level 0)
uniform float max_lod;       // log2(base size)
#include "common.glsl"

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (g.x >= size || g.y >= size) return;
    float sc = 2.0 * (float(g.x) + 0.5) / float(size) - 1.0;
    float tc = 2.0 * (float(g.y) + 0.5) / float(size) - 1.0;
    vec3 r = normalize(face_direction(g.z, sc, tc));
    float sgn = r.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sgn + r.z);
    float b = r.x * r.y * a;
    vec3 t1 = vec3(1.0 + sgn * r.x * r.x * a, sgn * b, -sgn * r.x);
    vec3 t2 = vec3(b, sgn + r.y * r.y * a, -r.y);
    vec3 sum = vec3(0.0);
    for (int k = 0; k < samples; ++k) {
        vec4 s = lobe_sample[k];
        vec3 l = s.x * t1 + s.y * t2 + (1.0 - s.z) * r;
        sum += textureLod(source, l, clamp(s.w + bias, 0.0, max_lod)).rgb;
    }
    imageStore(dst, g, vec4(sum / float(samples), 1.0));
}
