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
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(rgba16f, binding = 0) uniform readonly image3D src;
layout(rgba16f, binding = 1) uniform writeonly image3D dst;
layout(rgba16f, binding = 2) uniform readonly image3D opposite;  // the opposite face, the level of src
uniform ivec3 dst_size;
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
    float front_alpha = 0.0;
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
            ivec3 p = s + i * u + j * w;
            vec4 lo = imageLoad(src, p), hi = imageLoad(src, p + e);
            vec4 front = sign_ > 0 ? hi : lo;
            vec4 back = sign_ > 0 ? lo : hi;
            vec4 pair = front + (1.0 - front.a) * back;
            // the opposite face's pair: its front is this pair's back child
            vec4 olo = imageLoad(opposite, p), ohi = imageLoad(opposite, p + e);
            vec4 ofront = sign_ > 0 ? olo : ohi;
            vec4 oback = sign_ > 0 ? ohi : olo;
            vec3 orgb = ofront.rgb + (1.0 - ofront.a) * oback.rgb;
            float b = brightest(orgb);
            bool is_back = b > 0.0 && brightest(pair.rgb) <= MIP_BACK_RATIO * b;
            front_alpha += is_back ? 0.0 : pair.a;
            sum += pair;
        }
    vec4 out_ = 0.25 * sum;
    // the lit pairs' radiance per opacity, over the whole texel's opacity (unchanged where no pair is a back)
    if (front_alpha > 1e-6) out_.rgb = sum.rgb * (out_.a / front_alpha);
    imageStore(dst, g, out_);
}
