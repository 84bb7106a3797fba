#version 430
// One level of one face texture's anisotropic mip (realtime/techniques/vct/vct.py; vct_math.anisotropic_mip): for
// face direction s e_a, the 2x2x2 children pair up along axis a, the child on the s side in front:
// c = c_front + (1 - a_front) c_back (front to back, premultiplied); the four pairs are averaged.
// Cascades are stacked along z, each R_L deep at level L: children never cross a cascade.
//
// The pairs' opacities are averaged as they are (what the texel blocks), but its radiance is normalised by
// the opacity of the pairs that show some surface's front: rgb = a (sum_p rgb_p) / (sum_p' a_p'), p' the
// pairs that are not a back. A pair is a back where it is black while the same pair of the opposite face
// (the same two children composited the other way) is lit: the column holds only surfaces facing away from
// a viewer on the s side (the injection lights a face only where its surface faces it). Averaged as they
// are, such pairs dilute the lit ones: a texel of a curved wall (a bowl's) holds columns that start beside
// the wall, where it has turned out of the texel, and meet the back of the wall's other side (the solid
// under a bowl's inner surface) or of the wall itself where its normal's component along a changes sign; a
// cone can reach those columns only through the lit wall, yet they counted as black and opaque: the worst
// cone fully inside a uniformly lit bowl read 1.00 / 0.95 / 0.58 of its radiance at 32^3 / 64^3 / 128^3 (the
// coarser the levels it reads, the more such columns), 1.00 / 0.97 / 0.98 with this rule (both with the
// read's share for faces lit both ways, vct_trace.glsl's vct_front; without either, 0.90 / 0.80 / 0.57).
// Where every pair is a back (a thin wall's dark side) the radiance stays 0, as before; a surface dark on
// both sides (black pairs both ways) counts as a front, black and opaque.
// VCT_MIP_GLOSS: one face of the gloss texture (the glossy lobe's weight and weighted exponent, premultiplied by
// the coverage, the six faces side by side along x: vct_inject.comp) mipped by the same rule, all four channels
// as the radiance, with the face's own opacities (and the opposite face's) for the compositing and the backs
// told by the weight. Every output is clamped to half float's largest value: the normalisation divides by the
// front pairs' opacity, which may be small, and the exponent channel holds weights times up to 4096.
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(rgba16f, binding = 0) uniform readonly image3D src;
layout(rgba16f, binding = 1) uniform writeonly image3D dst;
uniform ivec3 dst_size;
#ifdef VCT_MIP_GLOSS
layout(rgba16f, binding = 3) uniform readonly image3D opacity;           // the face's opacities, src's level
layout(rgba16f, binding = 4) uniform readonly image3D opposite_opacity;  // the opposite face's
uniform int face;  // which of the six, side by side along x
vec4 load(ivec3 p) { return imageLoad(src, p + ivec3(2 * face * dst_size.x, 0, 0)); }
vec4 load_opposite(ivec3 p) { return imageLoad(src, p + ivec3(2 * (face ^ 1) * dst_size.x, 0, 0)); }
float alpha_at(ivec3 p) { return imageLoad(opacity, p).a; }
float opposite_alpha_at(ivec3 p) { return imageLoad(opposite_opacity, p).a; }
void store(ivec3 g, vec4 v) { imageStore(dst, g + ivec3(face * dst_size.x, 0, 0), v); }
#else
layout(rgba16f, binding = 2) uniform readonly image3D opposite;  // the opposite face, the level of src
vec4 load(ivec3 p) { return imageLoad(src, p); }
vec4 load_opposite(ivec3 p) { return imageLoad(opposite, p); }
float alpha_at(ivec3 p) { return imageLoad(src, p).a; }
float opposite_alpha_at(ivec3 p) { return imageLoad(opposite, p).a; }
void store(ivec3 g, vec4 v) { imageStore(dst, g, v); }
#endif
#define HALF_MAX 65504.0
uniform int axis;   // 0, 1, 2
uniform int sign_;  // +1 or -1
// a pair at most this fraction of the opposite face's pair is a back (vct_trace.glsl's VCT_BACK_RATIO)
#define MIP_BACK_RATIO 1e-3

float brightest(vec3 c) {
    return max(c.r, max(c.g, c.b));
}

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(g, dst_size))) return;
    ivec3 s = 2 * g;
    ivec3 e = ivec3(0);
    e[axis] = 1;
    ivec3 u = ivec3(0), w = ivec3(0);
    u[(axis + 1) % 3] = 1;
    w[(axis + 2) % 3] = 1;
    vec4 sum = vec4(0.0);
    float alpha = 0.0, front_alpha = 0.0;
#ifdef VCT_MIP_GLOSS
    vec4 front_sum = vec4(0.0);
#endif
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
            ivec3 p = s + i * u + j * w;
            ivec3 near = sign_ > 0 ? p + e : p, far = sign_ > 0 ? p : p + e;
            float a_front = alpha_at(near);
            vec4 pair = load(near) + (1.0 - a_front) * load(far);
#ifdef VCT_MIP_GLOSS
            float pair_alpha = a_front + (1.0 - a_front) * alpha_at(far);
#else
            float pair_alpha = pair.a;
#endif
            // the opposite face's pair: its front is this pair's back child
            vec3 orgb = load_opposite(far).rgb + (1.0 - opposite_alpha_at(far)) * load_opposite(near).rgb;
            float b = brightest(orgb);
            bool is_back = b > 0.0 && brightest(pair.rgb) <= MIP_BACK_RATIO * b;
            front_alpha += is_back ? 0.0 : pair_alpha;
            alpha += pair_alpha;
            sum += pair;
#ifdef VCT_MIP_GLOSS
            front_sum += is_back ? vec4(0.0) : pair;
#endif
        }
    vec4 out_ = 0.25 * sum;
    // the lit pairs' radiance per opacity, over the whole texel's opacity (unchanged where no pair is a back);
    // the gloss sums the front pairs alone (a back's weight is at most 1e-3 of the opposite's, times up to 4096)
#ifdef VCT_MIP_GLOSS
    if (front_alpha > 1e-6) out_ = front_sum * (0.25 * alpha / front_alpha);
#else
    if (front_alpha > 1e-6) out_.rgb = sum.rgb * (out_.a / front_alpha);
#endif
    store(g, min(out_, vec4(HALF_MAX)));
}
