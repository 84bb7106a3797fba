#version 430
// The split sum's DFG table (realtime/techniques/split_sum/dfg.py, its numpy mirror): texel (i, j) holds
//     A = 4 / N sum (1 - Fc) V (v.h) (n.l) / (n.h),   B = 4 / N sum Fc V (v.h) (n.l) / (n.h),   Fc = (1 - v.h)^5,
// at n.v = (i + 0.5) / size and roughness = (j + 0.5) / size, over N half vectors importance-sampled
// with density D(h) n.h from the Hammersley set (i / N, radical inverse of i): phi = 2 pi u,
// cos^2 = (1 - v) / (1 + (alpha^2 - 1) v), l = reflect(-v, h), samples with n.l <= 0 adding nothing.
// The host #defines LUT_FORMAT (rg32f, rg16f or rg8: the stored precision), LUT_F16 or LUT_U8 with it, and
// VISIBILITY_SEPARABLE for glTF's separable Smith V instead of the height-correlated one.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(LUT_FORMAT, binding = 0) uniform writeonly image2D table;
uniform int size;
uniform int samples;
uniform float min_alpha;  // PBR_MIN_ALPHA: alpha = max(roughness^2, min_alpha)
const float PI = 3.14159265358979323846;

// V = G2 / (4 n.l n.v) of the GGX lobe (Heitz 2014): a(x) = sqrt(alpha^2 + (1 - alpha^2) x^2)
float visibility(float nl, float nv, float a2) {
    float lam_l = sqrt(a2 + (1.0 - a2) * nl * nl);
    float lam_v = sqrt(a2 + (1.0 - a2) * nv * nv);
#ifdef VISIBILITY_SEPARABLE
    return 1.0 / ((nl + lam_l) * (nv + lam_v));
#else
    return 0.5 / (nv * lam_l + nl * lam_v);
#endif
}

// The value the stored format holds, rounded to nearest (ties to even) here: imageStore's own conversion is
// the driver's choice (Mesa llvmpipe truncates to half floats), the engines' tables are rounded to nearest
// (three.js' floatToHalf, numpy's float16). A rounded value converts exactly.
vec2 quantise(vec2 x) {
#if defined(LUT_F16)
    // half floats: 10 mantissa bits, subnormal below 2^-14
    vec2 e = max(floor(log2(max(abs(x), vec2(1e-30)))), vec2(-14.0));
    vec2 step = exp2(e - 10.0);
    return roundEven(x / step) * step;
#elif defined(LUT_U8)
    return roundEven(clamp(x, 0.0, 1.0) * 255.0) / 255.0;
#else
    return x;
#endif
}

void main() {
    ivec2 g = ivec2(gl_GlobalInvocationID.xy);
    if (g.x >= size || g.y >= size) return;
    float nv = (float(g.x) + 0.5) / float(size);
    float roughness = (float(g.y) + 0.5) / float(size);
    float alpha = max(roughness * roughness, min_alpha);
    float a2 = alpha * alpha;
    vec3 v = vec3(sqrt(1.0 - nv * nv), 0.0, nv);
    float A = 0.0;
    float B = 0.0;
    for (int k = 0; k < samples; ++k) {
        float u = float(k) / float(samples);
        float w = float(bitfieldReverse(uint(k))) * 2.3283064365386963e-10;  // radical inverse: / 2^32
        float denom = 1.0 + (a2 - 1.0) * w;
        float cos_h = sqrt((1.0 - w) / denom);
        float sin_h = sqrt(a2 * w / denom);
        float phi = 2.0 * PI * u;
        vec3 h = vec3(sin_h * cos(phi), sin_h * sin(phi), cos_h);
        float vh = clamp(dot(v, h), 0.0, 1.0);
        float nl = 2.0 * vh * cos_h - nv;  // l.z of l = 2 (v.h) h - v
        if (nl > 0.0) {
            float weight = visibility(nl, nv, a2) * vh * nl / cos_h;
            float fc = pow(1.0 - vh, 5.0);
            A += (1.0 - fc) * weight;
            B += fc * weight;
        }
    }
    imageStore(table, g, vec4(quantise(vec2(4.0 * A, 4.0 * B) / float(samples)), 0.0, 0.0));
}
