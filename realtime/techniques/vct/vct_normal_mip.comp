#version 430
// One level of one face-normal texture's mip (realtime/techniques/vct/vct.py; vct_math.normal_mip): the normal
// of what a viewer on the face's side sees of the texel's surfaces, weighted as the face texture composites
// their opacity. For face direction s e_a the 2x2x2 children pair up along axis a, the child on the s side
// in front: m = a_front n_front + (1 - a_front) a_back n_back (a the face texture's opacity of each child,
// n its stored normal, 0 where no surface faces s e_a: such a child still hides what is behind it); the
// four pairs are summed and the sum normalised (0 where it is 0), stored as vct_normal_bytes.glsl says. With it
// the spread: the children's normals' mean cosine about the stored normal (vct_math.normal_mean_length_mip).
// The cones read the normal's sign against their own direction (vct_trace.glsl's vct_read), the deferred glossy
// read the normal and its spread.
// Cascades are stacked along z, each R_L deep at level L: children never cross a cascade.
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(rgba8, binding = 0) uniform readonly image3D src;
layout(rgba8, binding = 1) uniform writeonly image3D dst;
layout(rgba16f, binding = 2) uniform readonly image3D face;  // the same face's radiance and opacity, the level of src
uniform ivec3 dst_size;
uniform int axis;   // 0, 1, 2
uniform int sign_;  // +1 or -1

#include "vct_normal_bytes.glsl"

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(g, dst_size))) return;
    ivec3 s = 2 * g;
    ivec3 e = ivec3(0), u = ivec3(0), w = ivec3(0);
    e[axis] = 1;
    u[(axis + 1) % 3] = 1;
    w[(axis + 2) % 3] = 1;
    vec3 m = vec3(0.0);
    // the spread: the children's means (unit direction times mean cosine) weighted alike, projected on the
    // stored normal, over the weights of the children that hold a normal: the mean cosine about the normal the
    // read uses (a plane's texels keep 1 whatever their opacities)
    vec3 spread = vec3(0.0);
    float held = 0.0;
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
            ivec3 p = s + i * u + j * w;
            ivec3 pf = sign_ > 0 ? p + e : p;  // the front child
            ivec3 pb = sign_ > 0 ? p : p + e;
            float af = clamp(imageLoad(face, pf).a, 0.0, 1.0), ab = clamp(imageLoad(face, pb).a, 0.0, 1.0);
            vec4 sf = imageLoad(src, pf), sb = imageLoad(src, pb);
            vec3 nf = vct_normal_decoded(sf), nb = vct_normal_decoded(sb);
            m += af * nf + (1.0 - af) * ab * nb;
            if (dot(nf, nf) > 1e-12) {
                spread += af * vct_normal_mean_length(sf) * normalize(nf);
                held += af;
            }
            if (dot(nb, nb) > 1e-12) {
                spread += (1.0 - af) * ab * vct_normal_mean_length(sb) * normalize(nb);
                held += (1.0 - af) * ab;
            }
        }
    float len = length(m);
    float mean_length = held > 0.0 && len > 1e-6 ? clamp(dot(spread, m / len) / held, 0.0, 1.0) : 1.0;
    imageStore(dst, g, vct_normal_encoded(len > 1e-6 ? m / len : vec3(0.0), mean_length));
}
