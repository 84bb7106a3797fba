// Voxel cone tracing through cascaded anisotropic voxel textures (realtime/techniques/vct/vct.py, realtime/techniques/vct/vct_math.py).
// Six 3D textures, one per face direction (+X, -X, +Y, -Y, +Z, -Z: what leaves a voxel toward it),
// each holding every cascade stacked along z (cascade c in slab [c, c+1) / C), each with its own
// anisotropic mip chain. rgb is radiance premultiplied by alpha, a the opacity.
uniform sampler3D vct_face_px;
uniform sampler3D vct_face_nx;
uniform sampler3D vct_face_py;
uniform sampler3D vct_face_ny;
uniform sampler3D vct_face_pz;
uniform sampler3D vct_face_nz;
// the same six faces' normals: the mean normal of the surfaces each face's light leaves (vct_read)
// (0 where no surface faces the face's direction: vct_normals.comp; the bytes: vct_normal_bytes.glsl), and in
// alpha how far those surfaces' normals spread about it (read by the deferred glossy read alone)
uniform sampler3D vct_normal_px;
uniform sampler3D vct_normal_nx;
uniform sampler3D vct_normal_py;
uniform sampler3D vct_normal_ny;
uniform sampler3D vct_normal_pz;
uniform sampler3D vct_normal_nz;
// columns: channel a = the largest coverage along axis a of the level-0 columns a texel holds
// (vct_column_mip.comp); read only by the cones' finer read
uniform sampler3D vct_columns;
uniform vec3 vct_centre;        // the cascades' common centre
uniform float vct_half_extent;  // of the finest cascade (cascade c: times 2^c)
uniform float vct_voxel;        // edge of a finest-cascade voxel (h0)
uniform int vct_resolution;     // voxels per side of every cascade
uniform int vct_cascades;
uniform float vct_step;         // step along a cone, in units of its diameter there
// samples a cone may take: enough to reach the outermost cascade's boundary (vct_math.max_cone_samples)
uniform int vct_max_samples;
uniform float vct_start_voxels;  // first sample's distance from the (offset) origin, in voxels of the origin's cascade
uniform float vct_normal_voxels; // the origin's offset along the normal, in the same voxels
// the faces hold radiance times this power of two (vct_math.radiance_scale: 1 unless a bright environment would
// overflow half float); vct_cone returns radiance in the scene's own units
uniform float vct_radiance_scale;
// the cones' radiance comes from mips >= this inside every cascade (the injection's bounce passes: 1), their
// opacity from vct_cone's own lod_min (vct_cone)
uniform float vct_rgb_lod_min;
// the opacity read is clamped below 1 so that its optical depth -ln(1 - alpha) stays finite (13.8: opaque)
#define VCT_MAX_ALPHA 0.999999
// the cones' finer read is split into up to 2^VCT_FINE_SPLIT reads, VCT_FINE_SPLIT levels finer (vct_cone)
#define VCT_FINE_SPLIT 2
// a face read against the cone counts as a surface's back where it is at most this fraction of the face
// the other way (vct_front, vct_axis_facing)
#define VCT_BACK_RATIO 1e-3
// A face no surface faces stores the normal 0 (bytes 128: vct_normal_bytes.glsl), which decodes to 0 exactly in
// exact arithmetic; a fused multiply-add in the decode (which GLSL allows) leaves about 6e-8 per component. A
// stored normal's smallest nonzero component is 1/127, so a normal counts as stored, and as facing a cone,
// only beyond this length
#define VCT_NORMAL_EPS 1e-6

// The share of the normalised Phong lobe of exponent N about r above the surface (n . l > 0), cos_r = n . r
// (vct_math.lobe_above_horizon mirrors it, with its derivation): the reference's Phong BSDF gives the lobe's
// directions below the horizon weight 0. The mean over the lobe's polar CDF cos(alpha) = xi^(1 / (N + 1))
// at VCT_HORIZON_SAMPLES midpoints of the azimuth share acos(clamp(-s cos(alpha) / (c sin(alpha)))) / pi.
// Far from the horizon, 1 or 0 without the sum: the lobe's share beyond the horizon is at most
// (1 - s^2)^((N + 1) / 2) (vct_math.HORIZON_EXACT_TAIL, the same rule).
#define VCT_HORIZON_SAMPLES 32
#define VCT_HORIZON_EXACT_TAIL 1e-4
float vct_lobe_above(float cos_r, float N) {
    float s = clamp(cos_r, -1.0, 1.0);
    if (pow(max(1.0 - s * s, 0.0), 0.5 * (N + 1.0)) < VCT_HORIZON_EXACT_TAIL) return s > 0.0 ? 1.0 : 0.0;
    float c = sqrt(max(0.0, 1.0 - s * s));
    float sum = 0.0;
    for (int k = 0; k < VCT_HORIZON_SAMPLES; ++k) {
        float ca = pow((float(k) + 0.5) / float(VCT_HORIZON_SAMPLES), 1.0 / (N + 1.0));
        float sa = sqrt(max(0.0, 1.0 - ca * ca));
        float t = c * sa > 0.0 ? -s * ca / (c * sa) : (s > 0.0 ? -2.0 : (s < 0.0 ? 2.0 : 0.0));
        sum += acos(clamp(t, -1.0, 1.0));
    }
    return sum / (3.14159265358979323846 * float(VCT_HORIZON_SAMPLES));
}

#ifdef VCT_GLOSS_READ
#include "vct_glossy_env.glsl"
// Per face, the glossy lobe's weight F ks V_g (rgb) and mean(F ks V_g) N (a), premultiplied by the coverage and
// mipped as the faces' radiance is (vct_inject.comp, vct_mip.comp's VCT_MIP_GLOSS); the six faces side by side
// along x in one texture (face f, in the order +X, -X, +Y, -Y, +Z, -Z, at x + f R_L of level L)
uniform sampler3D vct_gloss;
// the largest exponent the voxels sum (vct.py's MAX_EXPONENT)
#define VCT_MAX_EXPONENT 4096.0

// What a cone gathers of a face is the mean, over the cone's directions and over the surfaces the face's texel
// holds, of each surface's radiance toward the direction it is seen from; for the glossy term, of
// L_g(reflect(w, n_i), N) over the cone's directions w and the surfaces' normals n_i. Evaluated at the axis d
// and the mean normal m alone it is one sharp lobe: around a Phong torus (N = 50) the one bounce gathered into
// narrow bands four times the path tracer's brightest pixel (benchmarks/vct_bounce_images.py). Both spreads
// turn the mirror direction, so the mean is the environment convolved with the lobe, then with the spread of
// the mirrors about reflect(d, m). Zonal convolution multiplies Legendre coefficients (Funk-Hecke), so the first,
// the mean cosine, of the whole is the product of the parts' (vct_broadened_exponent), each spread taken as
// symmetric about its mean and only its first moment kept:
// - the cone: a reflection is an isometry of the sphere, so as w ranges over the cone reflect(w, m) ranges over
//   a cone of the same aperture, mean cosine (1 + cos a) / 2 for directions uniform over a cap of half-angle a
//   (`cone_mean_cos`, vct_math.cap_mean_cos);
// - the normals: a normal theta from the mean turns the mirror by up to 2 theta (by 2 theta in the plane of
//   incidence, less across it: the larger turn taken), and E[cos 2 theta] = 2 E[cos^2 theta] - 1 >= 2 l^2 - 1
//   (Jensen: E[cos^2] >= E[cos]^2, l = E[cos theta] the normals' mean cosine about the stored normal, stored with
//   it: vct_normal_bytes.glsl). To first order in the spread every distribution gives 1 - 4 (1 - l); 2 l^2 - 1
//   is the rim's (all the normals theta from the mean), the most spread a mean cosine l allows, so the read
//   broadens the lobe at least as much as the normals do (vct_reflection_spread_mean_cos). Toksvig (2005,
//   "Mipmapping normal maps") broadens a mipmapped normal map's highlight from the same length.
float vct_reflection_spread_mean_cos(float mean_length) {
    return max(2.0 * mean_length * mean_length - 1.0, 0.0);
}

// The normalised Phong lobe of exponent N (mean cosine (N + 1) / (N + 2)) convolved with a spread of mean cosine
// `spread_mean_cos`: the Phong lobe of mean cosine mu = (N + 1) / (N + 2) spread_mean_cos, N' = (2 mu - 1) /
// (1 - mu), the lobe vct_glossy_env.glsl reads (vct_math.broadened_exponent); broader than the cosine lobe
// (mu <= 1/2), 0.
float vct_broadened_exponent(float N, float spread_mean_cos) {
    float mu = (N + 1.0) / (N + 2.0) * spread_mean_cos;
    return mu <= 0.5 ? 0.0 : (2.0 * mu - 1.0) / (1.0 - mu);
}

// The glossy radiance a face's surfaces send toward v (unit, from the surface toward the viewer), premultiplied
// as the face's radiance is: g the face's gloss texel, m its stored normal. Six faces that each store the
// radiance toward their own axis hand a cone along -v the blend of six directions' reflections: around a
// Phong torus (N = 50) that put 39 % on its one bounce in a numpy model exact in all else
// (benchmarks/vct_glossy_storage.py), 24 points of it the environment's radiance taken along the faces'
// directions instead of the cone's, 15 the sender's visibility, which the faces still blend (V_g per face).
// Evaluated here, the environment's part is the sender's own lobe about the mirror of v in m,
// F ks V_g H(m . v, N) L_g(reflect(-v, m), N): the paper's glossy term toward v with the face's visibility V_g
// and its Fresnel F (Schlick's at the face's axis: 1 for Phong). In the mips m is the faces' opacity-weighted
// mean normal and N the weight-weighted mean exponent. The environment's lobe is read broadened by the cone's
// aperture and the normals' spread (vct_broadened_exponent, above; `mean_length` the stored normal's l,
// `cone_mean_cos` the reading cone's); the horizon share keeps the surfaces' own N, the BSDF's cut-off.
vec3 vct_gloss_radiance(vec4 g, vec3 m, float mean_length, vec3 v, float cone_mean_cos) {
    float weight = (g.r + g.g + g.b) / 3.0;
    if (weight <= 0.0 || dot(m, m) <= VCT_NORMAL_EPS * VCT_NORMAL_EPS) return vec3(0.0);
    vec3 n = normalize(m);
    float c = dot(n, v);
    if (c <= 0.0) return vec3(0.0);  // the surfaces face away from the viewer
    float N = clamp(g.a / weight, 0.0, VCT_MAX_EXPONENT);
    return g.rgb * (vct_lobe_above(c, N) * vct_radiance_scale)
         * vct_glossy_env(reflect(-v, n), vct_broadened_exponent(N, cone_mean_cos
                                                                   * vct_reflection_spread_mean_cos(mean_length)));
}
#endif

// the finest cascade holding p, half a voxel inside its box (-1: outside every cascade)
int vct_cascade_of(vec3 p) {
    vec3 q = abs(p - vct_centre);
    float off = max(q.x, max(q.y, q.z));
    float he = vct_half_extent;
    for (int c = 0; c < vct_cascades; ++c) {
        if (off <= he * (1.0 - 1.0 / float(vct_resolution))) return c;
        he *= 2.0;
    }
    return -1;
}

// One texel's value at mip `level` of cascade c, the texel holding `local` (nearest: no trilinear blend).
// Opacity is read nearest because trilinear interpolation turns a one-texel opaque layer into a tent
// alpha(x) = 1 - |x| (x in texels from its centre) whose optical depth int -ln(1 - alpha(x)) dx over
// [-1, 1] is 2: a closed wall would pass e^-2 = 13.5 % of the light at every level. Nearest keeps the
// opacity field piecewise constant, exact for a voxel of opacity alpha; steps of at most one texel
// (ds / s = step <= 1 with the default 0.5) cannot cross a layer of texels without a sample inside it.
// `slot`: which of the grids a texture holds side by side along x (the gloss texture's six faces; 0 elsewhere).
vec4 vct_texel(sampler3D tex, int slot, vec3 local, int c, int level) {
    int r = max(vct_resolution >> level, 1);
    ivec3 i = clamp(ivec3(floor(local * float(r))), ivec3(0), ivec3(r - 1));
    return texelFetch(tex, ivec3(i.x + slot * r, i.y, i.z + c * r), level);
}

// the cone's fractional mip: the two levels around it, blended linearly (mip-linear, texel-nearest)
vec4 vct_slot_fetch(sampler3D tex, int slot, vec3 local, int c, float mip) {
    int l0 = int(floor(mip));
    int l1 = min(l0 + 1, int(log2(float(vct_resolution))));
    float f = mip - float(l0);
    vec4 a = vct_texel(tex, slot, local, c, l0);
    return f > 0.0 ? mix(a, vct_texel(tex, slot, local, c, l1), f) : a;
}

vec4 vct_fetch(sampler3D tex, vec3 local, int c, float mip) {
    return vct_slot_fetch(tex, 0, local, c, mip);
}

#include "vct_normal_bytes.glsl"

// The stored bytes of one axis's face normal (vct_normal_bytes.glsl decodes them): the face pointing toward +a
// (`positive`, from `toward_pos`) or toward -a, at the cone's fractional mip, read as vct_fetch reads the faces
// (the decoding is affine, so the blend of the two levels' stored values is the blend of their normals). The
// nearer level alone costs one fetch in place of two (a 64^3 frame of cornell-open: 18 % more than without the
// normals, against 31 % with the blend), but where the cone's mip lies between a level whose texel holds the
// surface and one whose texel does not, the blended radiance keeps the first level's light while the nearer
// level's empty normal drops it: a lit plane seen from its front read 0.56 L.
vec4 vct_axis_stored_normal(sampler3D toward_pos, sampler3D toward_neg, bool positive, vec3 local, int c, float mip) {
    return positive ? vct_fetch(toward_pos, local, c, mip) : vct_fetch(toward_neg, local, c, mip);
}

// the radiance per opacity of a face read (its brightest channel; 0 where transparent)
float vct_rho(vec4 f) {
    return f.a > 1e-6 ? max(f.r, max(f.g, f.b)) / f.a : 0.0;
}

// The share of an axis's face read against the cone that can carry light toward it. A surface of normal n
// seen by a cone along d with n.d < 0 shows its front, but the cone reads it axis by axis, and on an axis
// with n_a d_a > 0 the face against d is that surface's back: black (the injection lights a face only where
// the surface faces it), yet opaque by its coverage. Counted in the radiance's normalisation (rgb / alpha) it
// darkens a lit curved surface: inside a bowl whose walls all show L, the cones gathered 0.72 to 0.99 of
// pi L (1 - V) and less as the resolution grew. Such a face is black while the face the other way, in the
// same texel, is lit: it then counts in the opacity only (share 0). A coarse texel of a curved surface holds
// both: on an axis where the surface turns within the texel (n_a changes sign), the face against d is lit
// where n_a d_a < 0 and black where n_a d_a > 0, and the face along d the other way round, so both are lit
// and the face against d shows L only on the share of its opacity that faces the cone: its radiance per
// opacity rho_a = rgb_a / alpha_a is L times that share (a bowl's down-the-wall cone at 128^3 read a
// level-3 z face of 0.0004 / 0.10 against 0.021 along, its x and y faces 0.21 per opacity: counted whole, the
// z face brought the sample's radiance to 0.162 of the wall's 0.208). That share
// is estimated as rho_a / rho_ref (at most 1), rho_ref the rho of the face read against d of the largest
// weighted opacity d_a^2 alpha_a (the dominant one), on an axis whose face along d is lit (mixed); 1 where it
// is black (no back of a lit surface on this axis: two walls of different radiance meeting in a corner keep
// their own weights). Not the brightest face's rho: a coarse texel holding both sides of a thin wall often
// has the far side's light on one axis, which the cone cannot see (inside a bowl whose outer wall shows 2 L,
// the brightest as reference read up to 1.66 L at 64^3, the dominant 1.03 L). Only the
// normalisation changes, never the numerator: the faces pointing along d add no light (a thin wall's dark
// side stays black, for walls along the grid's axes; an oblique wall needs the faces' normals: vct_read), and a face
// dark on both sides counts whole (a dark surface is opaque and black).
float vct_front(vec4 against, vec3 along, float rho_ref) {
    float a = max(against.r, max(against.g, against.b));
    float b = max(along.r, max(along.g, along.b));
    if (b <= 0.0) return 1.0;
    if (a <= VCT_BACK_RATIO * b) return 0.0;
    return rho_ref > 0.0 ? clamp(vct_rho(against) / rho_ref, 0.0, 1.0) : 1.0;
}

// Which side of a two-sided surface a texel shows a cone along d, one axis's term t_a: -1 where the face
// against d is black though a surface faces the cone on this axis there (a normal m is stored) while the face
// along d is lit, +1 where the face against d is lit and the face along d black, 0 otherwise (both lit: a surface
// turning inside the texel; both black; or no surface facing the cone on this axis). vct_read sums the terms
// weighted by |d_a| alpha_a and drops the texel's light where the sum is negative. The derivation: a wall of
// unit normal n crossing a voxel covers axis a by alpha_a = |n_a| / |n|_inf (vct_inject.comp's coverage); with
// its n side lit and its -n side dark, the face against d on axis a shows the lit side where n_a d_a < 0
// (t_a = +1) and the dark side, which faces the cone, where n_a d_a > 0 (t_a = -1), so
// sum_a t_a |d_a| alpha_a = -n . d / |n|_inf: negative where the cone meets the dark side. That is a thin
// wall's inner side seen from inside a closed box: the per-face normals already drop a lit face whose own
// surface faces away, but a coarse texel also holds lit faces of other walls behind the cone (the box's far
// wall, its outer side facing the cone), which its dark side hides. A one-sided surface seen from behind
// has no surface facing the cone on that axis (no normal stored): its term is 0, as its back is neither
// side of a wall; the per-face normals keep its light out. A texel near a cone's start holding such a
// surface the cone moves away from (a room's side wall beside the floor it leaves) then does not cancel the
// fronts the texel also holds (with t_a = -1 for any black face against a lit one, cornell-open's indirect
// energy fell from 0.90 to 0.88 of the path tracer's at 64^3, 64^2 pixels). The sum is exact for one wall in a level-0
// voxel; the mips composite the opacities front to back, so there it is approximate.
float vct_axis_facing(vec3 against, vec3 along, vec3 m) {
    float a = max(against.r, max(against.g, against.b));
    float b = max(along.r, max(along.g, along.b));
    if (b > 0.0 && a <= VCT_BACK_RATIO * b) return dot(m, m) > VCT_NORMAL_EPS * VCT_NORMAL_EPS ? -1.0 : 0.0;
    if (a > 0.0 && b <= VCT_BACK_RATIO * a) return 1.0;
    return 0.0;
}

// Which axes' coverage can block a cone along unit d (1) and which cannot (0), from the mean normals of the
// texel's faces against d (m) and along d (q) on each axis. A face's coverage alpha_a is its surfaces' cover of
// the texel's cross-section along axis a, the same on its two faces (vct_inject.comp): a plane of normal n
// covers |n_a| / |n|_inf of it whichever side it is seen from. But a ray meets a surface only through its
// front where the surface is one side of a closed solid or a one-sided surface the ray starts in front of: a
// ray from outside a closed solid that reaches a back (n . d > 0) has crossed a front before it, so the fronts
// alone decide the visibility, and the backs' coverage blocks nothing that the fronts do not. A coarse texel,
// though, also holds surfaces behind the sample that the cone moves away from (a room's wall beside the floor
// a cone leaves, the far side of a tube the cone has passed), seen from behind, and their coverage blocked
// the cone as if it crossed them. A surface covering axis a has n_a != 0, so it is in the face against d
// (n_a d_a < 0) or the face along d (n_a d_a > 0) on that axis; it faces the cone where n . d < 0, which the
// faces' mean normals test (exact for one surface a face; in the mips a mean weighted by the faces'
// opacities). A two-sided wall has both sides, one of which faces the cone: it still blocks from either side.
// Measured against ray casting (300 random surface points a scene, 96 cosine-weighted rays each, the six
// shading cones' visibility, 32^3 / 64^3 / 128^3), the mean error of the visibility: torus-phong 0.031 / 0.032 /
// 0.034 -> 0.022 / 0.023 / 0.023, sphere-on-plane 0.094 / 0.083 / 0.079 -> 0.092 / 0.080 / 0.073, bowl-diffuse
// and cornell-open within 0.002 of before (their bias toward over-occlusion smaller by 0.002-0.013). A surface
// whose back a ray from a shaded point can reach, a one-sided surface seen from behind that is no side of a
// closed solid, no longer blocks through the coarse read: the finer read (vct_cone) keeps every surface's
// coverage, whichever way it faces, so such a surface still blocks where it crosses the cone's axis.
vec3 vct_facing_axes(vec3 mx, vec3 my, vec3 mz, vec3 qx, vec3 qy, vec3 qz, vec3 d) {
    bvec3 against = lessThan(vec3(dot(mx, d), dot(my, d), dot(mz, d)), vec3(-VCT_NORMAL_EPS));
    bvec3 along = lessThan(vec3(dot(qx, d), dot(qy, d), dot(qz, d)), vec3(-VCT_NORMAL_EPS));
    return vec3(against.x || along.x ? 1.0 : 0.0, against.y || along.y ? 1.0 : 0.0, against.z || along.z ? 1.0 : 0.0);
}

// What a cone travelling along unit d reads at p from cascade c, mip `mip`: the faces pointing against d.
// Returns (sum_a d_a^2 rgb_a, sum_a d_a^2 alpha_a) and, in `alphas`, each axis's face opacity alpha_a:
// the step's transmittance combines these in the optical-depth domain (vct_cone). `front` is the part of
// the weighted opacity that can carry light toward the cone (vct_front).
// A face adds light only where the surfaces it holds face the cone as a whole: its stored normal m (the
// mean normal of the surfaces facing the face's direction, mipped with the faces' opacities:
// vct_normals.comp, vct_normal_mip.comp) has m . d < 0. The face against d on axis a is lit by a surface of
// normal n where n_a d_a < 0, one component of n . d only: a one-sided plane oblique to the grid, seen from
// behind (n . d > 0), shows the cone its lit face on a minor axis (n_a d_a < 0 there), which would pass its
// light to the cone. A face whose surfaces face away adds its opacity only (a back, as in vct_front), and that
// only where vct_facing_axes lets it; a face no surface faces has m = 0 and holds no light. The rgb is 0 where
// the texel shows the cone the dark side of a two-sided wall (vct_axis_facing).
vec4 vct_read(vec3 p, vec3 d, float cone_mean_cos, int c, float mip, out vec3 alphas, out float front) {
    float he = vct_half_extent * exp2(float(c));
    vec3 local = (p - vct_centre) / (2.0 * he) + 0.5;
    vec3 w = d * d;
    vec4 x = d.x > 0.0 ? vct_fetch(vct_face_nx, local, c, mip) : vct_fetch(vct_face_px, local, c, mip);
    vec4 y = d.y > 0.0 ? vct_fetch(vct_face_ny, local, c, mip) : vct_fetch(vct_face_py, local, c, mip);
    vec4 z = d.z > 0.0 ? vct_fetch(vct_face_nz, local, c, mip) : vct_fetch(vct_face_pz, local, c, mip);
    // the faces pointing along d: what the same texels show the other way
    vec3 ox = (d.x > 0.0 ? vct_fetch(vct_face_px, local, c, mip) : vct_fetch(vct_face_nx, local, c, mip)).rgb;
    vec3 oy = (d.y > 0.0 ? vct_fetch(vct_face_py, local, c, mip) : vct_fetch(vct_face_ny, local, c, mip)).rgb;
    vec3 oz = (d.z > 0.0 ? vct_fetch(vct_face_pz, local, c, mip) : vct_fetch(vct_face_nz, local, c, mip)).rgb;
    // the against faces' normals, and which of those faces' surfaces face the cone (1) or not (0)
    vec4 smx = vct_axis_stored_normal(vct_normal_px, vct_normal_nx, d.x <= 0.0, local, c, mip);
    vec4 smy = vct_axis_stored_normal(vct_normal_py, vct_normal_ny, d.y <= 0.0, local, c, mip);
    vec4 smz = vct_axis_stored_normal(vct_normal_pz, vct_normal_nz, d.z <= 0.0, local, c, mip);
    vec3 mx = vct_normal_decoded(smx), my = vct_normal_decoded(smy), mz = vct_normal_decoded(smz);
    vec3 sees = vec3(lessThan(vec3(dot(mx, d), dot(my, d), dot(mz, d)), vec3(-VCT_NORMAL_EPS)));
    // the along faces' normals: the surfaces covering each axis that face along d there
    vec4 sqx = vct_axis_stored_normal(vct_normal_px, vct_normal_nx, d.x > 0.0, local, c, mip);
    vec4 sqy = vct_axis_stored_normal(vct_normal_py, vct_normal_ny, d.y > 0.0, local, c, mip);
    vec4 sqz = vct_axis_stored_normal(vct_normal_pz, vct_normal_nz, d.z > 0.0, local, c, mip);
    vec3 qx = vct_normal_decoded(sqx), qy = vct_normal_decoded(sqy), qz = vct_normal_decoded(sqz);
#ifdef VCT_GLOSS_READ
    // the glossy light the faces' surfaces send toward the cone (the faces against d, toward -d) and the other
    // way (the faces along d, toward d), evaluated for this direction (vct_gloss_radiance)
    x.rgb += vct_gloss_radiance(vct_slot_fetch(vct_gloss, d.x > 0.0 ? 1 : 0, local, c, mip), mx, vct_normal_mean_length(smx), -d, cone_mean_cos);
    y.rgb += vct_gloss_radiance(vct_slot_fetch(vct_gloss, d.y > 0.0 ? 3 : 2, local, c, mip), my, vct_normal_mean_length(smy), -d, cone_mean_cos);
    z.rgb += vct_gloss_radiance(vct_slot_fetch(vct_gloss, d.z > 0.0 ? 5 : 4, local, c, mip), mz, vct_normal_mean_length(smz), -d, cone_mean_cos);
    ox += vct_gloss_radiance(vct_slot_fetch(vct_gloss, d.x > 0.0 ? 0 : 1, local, c, mip), qx, vct_normal_mean_length(sqx), d, cone_mean_cos);
    oy += vct_gloss_radiance(vct_slot_fetch(vct_gloss, d.y > 0.0 ? 2 : 3, local, c, mip), qy, vct_normal_mean_length(sqy), d, cone_mean_cos);
    oz += vct_gloss_radiance(vct_slot_fetch(vct_gloss, d.z > 0.0 ? 4 : 5, local, c, mip), qz, vct_normal_mean_length(sqz), d, cone_mean_cos);
#endif
    // An axis's coverage blocks the cone only where a surface covering that axis faces it (vct_facing_axes)
    alphas = clamp(vec3(x.a, y.a, z.a), 0.0, 1.0) * vct_facing_axes(mx, my, mz, qx, qy, qz, d);
    // the dominant face's rho: the one of the largest weighted opacity w_a alpha_a
    vec3 wa = w * alphas;
    float rho_ref = wa.x >= wa.y && wa.x >= wa.z ? vct_rho(x) : (wa.y >= wa.z ? vct_rho(y) : vct_rho(z));
    vec3 ws = w * sees;
    front = ws.x * alphas.x * vct_front(x, ox, rho_ref) + ws.y * alphas.y * vct_front(y, oy, rho_ref)
          + ws.z * alphas.z * vct_front(z, oz, rho_ref);
    vec3 ad = abs(d) * alphas;
    float facing = ad.x * vct_axis_facing(x.rgb, ox, mx) + ad.y * vct_axis_facing(y.rgb, oy, my)
                 + ad.z * vct_axis_facing(z.rgb, oz, mz);
    float opacity = dot(w, vec3(x.a, y.a, z.a));
    return facing < 0.0 ? vec4(0.0, 0.0, 0.0, opacity) : vec4(ws.x * x.rgb + ws.y * y.rgb + ws.z * z.rgb, opacity);
}

// Transmittance of a step ds along unit d through a texel of edge vs whose faces have opacities `alphas`
// (vct_math.step_transmittance mirrors it). A face's alpha is the opacity of one texel's length along its
// axis (the coverage of its cross-section by the surfaces in it), so Beer-Lambert gives the optical depth
// per length tau_a = -ln(1 - alpha_a) / vs along axis a. Along d the extinction is that of the surfaces'
// cross-section projected onto d: a surface element of normal e_a blocks |d . e_a| = |d_a| of its area
// seen along d, so T = exp(-ds sum_a |d_a| tau_a) = prod_a (1 - alpha_a)^(|d_a| ds / vs). A layer of
// normal e_a crossed obliquely is crossed over the length vs / |d_a|: optical depth -ln(1 - alpha_a),
// whatever the angle (a thin wall is as opaque to a grazing ray as to a normal one; the squared cosines
// d_a^2, which sum to 1, would give it |d_a| of that: a wall transparent along itself, seen at grazing
// angles, would let the light through). A step of half a texel counts half a texel's optical depth.
float vct_step_transmittance(vec3 alphas, vec3 d, float ds, float vs) {
    vec3 tau = -log(1.0 - min(alphas, vec3(VCT_MAX_ALPHA)));
    return exp(-dot(abs(d), tau) * ds / vs);
}

// One cone from `origin` along unit d with tan(half-angle) `tan_half`, front to back from distance t0:
// (radiance gathered, occlusion). The level (vct_math.sample_lod mirrors it) follows the cone's diameter
// 2 t tan_half (at least h0): lod = log2(diameter / h0) over the whole pyramid, the cascade floor(lod)
// but never finer than the finest holding the sample, the mip lod - cascade (vct_math.Cascades.level_of).
// `lod_min` floors the level read (and the mip inside its cascade); `vct_rgb_lod_min` the radiance's alone.
// The footprint cap keeps the lookup off the surface the cone leaves (plane n through `surface`): the
// trilinear, mip-linear lookup at lod reads the 2x2x2 texels around p at levels floor(lod) and ceil(lod);
// those of the coarser level, of edge s = h0 2^ceil(lod), reach 1.5 s from p along each axis, so
// 1.5 s |n|_1 below p along n (|n|_1 = |n.x| + |n.y| + |n.z|: a box's extent along n per unit edge).
// The surface's own voxels (finest, conservative: their boxes cross the plane) reach h0 |n|_1 above it.
// The lookup stays off them while height - 1.5 s |n|_1 >= h0 |n|_1, i.e. s <= s_max =
// (height / |n|_1 - h0) / 1.5, so lod <= lod_cap = floor(log2(s_max / h0)). Where the cone is narrower
// than that its own width governs; where wider (a plane's diffuse cones, whose 2 tan_half >= 0.9 exceed
// the cap's at most 2/3 of the height, all along the cone) the sample reads the capped level.
// The cascade and the mip inside it (`mip`) that read a texel of lod (vct_math.Cascades.level_of mirrors it):
// the cascade floor(lod), never finer than `inside`, the finest holding the sample. `mip_floor` also floors the
// mip inside the cascade: the injection's bounce passes rewrite level 0 of every cascade, so their cones take a
// texel of lod from a finer cascade's mip >= mip_floor, never from a coarser cascade's level 0.
int vct_level(float lod, float mip_floor, int inside, out float mip) {
    int c = clamp(int(floor(lod - mip_floor)), inside, vct_cascades - 1);
    mip = clamp(max(lod - float(c), mip_floor), 0.0, log2(float(vct_resolution)));
    return c;
}

vec4 vct_cone(vec3 origin, vec3 d, float tan_half, float t0, float lod_min, vec3 surface, vec3 n) {
    vec4 acc = vec4(0.0);
    // the mean cosine of the cone's directions about its axis, uniform over its cap: (1 + cos a) / 2
    float cone_mean_cos = 0.5 * (1.0 + inversesqrt(1.0 + tan_half * tan_half));
    float t = t0;
    for (int i = 0; i < vct_max_samples && acc.a < 0.995; ++i) {
        vec3 p = origin + t * d;
        int inside = vct_cascade_of(p);
        bool last = inside < 0;
        if (last) {
            // leaving the voxels: one last sample where the cone crosses the outermost cascade's boundary
            // (a wall near the boundary is not stepped over), then open sky
            float he = vct_half_extent * exp2(float(vct_cascades - 1)) * (1.0 - 1.0 / float(vct_resolution));
            vec3 q = clamp(p - vct_centre, vec3(-he), vec3(he));
            p = vct_centre + q;
            inside = vct_cascades - 1;
            if (i == 0) break;
        }
        float n1 = abs(n.x) + abs(n.y) + abs(n.z);
        float s_max = (dot(p - surface, n) / n1 - vct_voxel) / 1.5;
        float lod_cap = floor(log2(max(s_max, vct_voxel) / vct_voxel));
        float lod_cone = log2(max(2.0 * t * tan_half, vct_voxel) / vct_voxel);
        float diam = vct_voxel * exp2(min(lod_cone, lod_cap));
        float lod = max(min(lod_cone, lod_cap), lod_min);
        float mip;
        int c = vct_level(lod, lod_min, inside, mip);
        vec3 alphas;
        float front;
        vec4 s = vct_read(p, d, cone_mean_cos, c, mip, alphas, front);
        // The injection's bounce passes rewrite level 0's rgb in every cascade while their cones read, so the
        // radiance comes from mips >= vct_rgb_lod_min (the texel of lod from a finer cascade's mip, as above);
        // the opacity, which they rewrite unchanged, is read where the direct pass reads it, so that the direct
        // light a bounce pass re-injects has the direct pass's visibility (read from levels >= 1, a level-1
        // texel near the surface holds the surface's own layer, which occludes its own cones)
        if (vct_rgb_lod_min > lod_min) {
            float mip_rgb;
            int c_rgb = vct_level(max(lod, vct_rgb_lod_min), vct_rgb_lod_min, inside, mip_rgb);
            if (c_rgb != c || mip_rgb != mip) {
                vec3 unused;
                s.rgb = vct_read(p, d, cone_mean_cos, c_rgb, mip_rgb, unused, front).rgb;
            }
        }
        // Opacity also from the finer level whose texel is the step (ds = vct_step * diam: log2(vct_step)
        // levels below; the cascade's own level 0 at the finest): a coarse texel at a surface's edge averages
        // the surface with the open space beyond it, which a cone inside the surface's bounds cannot reach
        // without crossing it (a closed box's corner texels read 1 - 2/16 transparent at 16 voxels a texel);
        // the finer texel holding the axis is the one the cone's centre crosses, and texels as long as the
        // step cannot be stepped over. The smaller transmittance of the two is kept (a small occluder off the
        // axis still counts through the coarse texel). The finer read takes the texel's most covered column
        // (the column texture, max-mipped), not its mean coverage: the axis crosses one column, and where
        // a texel of a box's roof reaches past the wall beside it, the open columns beyond the wall are
        // what the cone only reaches through the wall, which coverage counts as transparent along the
        // wall's own plane (a mean would let 1 - 0.82 of the light through a 128^3 box's roof corner).
        float fine_level = max(mip + log2(vct_step), 0.0);
        float he_c = vct_half_extent * exp2(float(c));
        float ds = vct_step * diam;
        // opacity of a step ds through a texel of edge vs at this level (Beer-Lambert, vct_step_transmittance);
        // the radiance it adds is the texel's (rgb / alpha, premultiplied) times that opacity. Each read's
        // opacities are per its own texel's length: a finer read's texel is vf (its share of the step, or
        // level 0's), so its share of the step crosses (ds / parts) / vf of it.
        float vs = vct_voxel * exp2(float(c) + mip);
        // the radiance's normalisation: the opacity of the faces that can carry light toward the cone
        // (vct_front); all of it where none can (a texel of backs only: its rgb is 0 anyway)
        float a0 = clamp(front > 1e-6 ? front : s.a, 0.0, 1.0);
        // The finer read's texel is the step, so it holds columns beside the axis as well as the axis's own:
        // an occluder beside the axis within it counts as on it (cornell-open's indirect energy at 64^3:
        // 0.82 of the path tracer's). Split into 2^m reads m levels finer, 1 / 2^m of the step apart (each
        // texel as long as its share of the step, so none can be stepped over), the axis's column is known
        // to 2^-m of that width: 0.85 with m = 1, 0.86 with m = 2 and m = 4 (converged: m <= 2 kept).
        int m = int(min(floor(fine_level), float(VCT_FINE_SPLIT)));
        float fl = fine_level - float(m);
        float vf = vct_voxel * exp2(float(c) + fl);
        int parts = 1 << m;
        float T_fine = 1.0;
        for (int k = 0; k < parts; ++k) {
            vec3 q = p - (float(k) / float(parts)) * ds * d;
            vec3 f = clamp(vct_fetch(vct_columns, (q - vct_centre) / (2.0 * he_c) + 0.5, c, fl).xyz, 0.0, 1.0);
            T_fine *= vct_step_transmittance(f, d, ds / float(parts), vf);
        }
        float a = 1.0 - min(vct_step_transmittance(alphas, d, ds, vs), T_fine);
        vec3 rgb = a0 > 1e-6 ? s.rgb * (a / a0) : vec3(0.0);
        acc.rgb += (1.0 - acc.a) * rgb;
        acc.a += (1.0 - acc.a) * a;
        if (last) break;
        t += ds;
    }
    return vec4(acc.rgb / vct_radiance_scale, acc.a);
}

// the voxel size at p (that of the finest cascade holding it; h0 outside them all)
float vct_local_voxel(vec3 p) {
    int c = vct_cascade_of(p);
    return vct_voxel * exp2(float(max(c, 0)));
}

// tangent frame of n, as vct_math.tangent_frame
mat3 vct_frame(vec3 n) {
    vec3 helper = abs(n.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
    vec3 t = normalize(cross(helper, n));
    return mat3(t, cross(n, t), n);
}

uniform int vct_cone_count;
uniform vec3 vct_cone_dir[9];     // in the normal's frame (z = n)
uniform float vct_cone_weight[9]; // the irradiance quadrature's weights, sum pi (vct_math.cone_set)
uniform float vct_cone_tan;       // tan of the diffuse cones' half-angle

// The diffuse cones about n at x: (sum_k w_k L_k = gathered irradiance, sum_k w_k (1 - a_k) / pi =
// cosine-weighted visibility)
vec4 vct_diffuse(vec3 x, vec3 n, float lod_min) {
    float h = vct_local_voxel(x);
    vec3 origin = x + vct_normal_voxels * h * n;
    mat3 f = vct_frame(n);
    vec3 E = vec3(0.0);
    float V = 0.0;
    for (int k = 0; k < vct_cone_count; ++k) {
        vec4 r = vct_cone(origin, normalize(f * vct_cone_dir[k]), vct_cone_tan, vct_start_voxels * h, lod_min, x, n);
        E += vct_cone_weight[k] * r.rgb;
        V += vct_cone_weight[k] * (1.0 - r.a);
    }
    return vec4(E, V / 3.14159265358979323846);
}
