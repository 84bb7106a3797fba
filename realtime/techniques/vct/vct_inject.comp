#version 430
// Per voxel of one cascade (realtime/techniques/vct/vct.py), level 0 of the six face textures.
// OCCUPANCY pass: alpha = the surface's coverage along the face's axis (coverage below), rgb = 0 (the
// opacity the visibility cones of the INJECT pass trace through, after its mips are built); and the
// column texture: the same coverage per axis in its rgb (the cones' finer read, max-mipped).
// INJECT pass: face f holds the radiance that leaves the voxel toward a_f, i.e. what a viewer looking
// along -a_f sees of the surface inside it, premultiplied by the coverage along its axis (its alpha):
// - a face some triangle faces (W_f = sum max(0, n . a_f) > 0): the surface's radiance toward v = a_f,
//   n_f its weighted mean normal, the paper's reflectance L = (1 - F) kd / pi (E V_d + E_b)
//   + F ks H (L_g(r) V_g + L_b), F = f0 + schlick (1 - f0) (1 - n.v)^5, r = reflect(-v, n_f), H the Phong
//   lobe's share above the surface (vct_lobe_above: the reference's BSDF weighs the rest 0). E is the
//   environment's SH9 irradiance (the scene's diffuse technique's M when it is SH9), L_g the environment
//   convolved with the normalised Phong lobe (N + 1) / (2 pi) (r.l)^N (glossy_env below). The diffuse term's V_d
//   is the diffuse cones' visibility through the voxels themselves and E_b what they gather from the
//   previous bounce (inject = 2); the glossy term's V_g and L_b are those of one cone along r with the
//   lobe's own half-angle (glossy_lobe below). The bounce passes read mips >= 1 only: level 0's radiance
//   is being written. A viewer along -a_f looking at a plane crossing the voxel hits its front whenever
//   a_f . n > 0, so the face carries the full radiance (not a fraction n . a_f);
// - any other face: black. A face no triangle faces whose opposite face none faces either has a_f in
//   the surfaces' plane (n_a = 0 for all of them), so its coverage is 0 and it holds nothing: a cone
//   reads rgb / alpha over the faces weighted by d_a^2, so a plane of radiance L with normal +y reads L
//   from every direction with d_y != 0 (its whole exitance pi L over its front hemisphere), and no side
//   face carries one side of a thin wall's light to the other;
// - a face looking at a surface's back (the opposite face is faced): black, opaque by its coverage.
// VCT_DEFERRED_GLOSSY (a scene with glossy surfaces and the frame's environment store, vct.py): a face's
// radiance leaves out the glossy term's L_g(r) V_g, whose environment part depends on the direction the face
// is read from, not on the face's axis; its gloss texel holds F ks V_g and the exponent instead, and a cone
// reading the face evaluates H L_g toward itself (vct_trace.glsl's vct_gloss_radiance).
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
#include "vct_voxel_sums.glsl"
layout(std430, binding = 2) readonly buffer SH { mat4 M[3]; vec4 coeffs[9]; };
layout(rgba16f, binding = 0) uniform writeonly image3D out_px;
layout(rgba16f, binding = 1) uniform writeonly image3D out_nx;
layout(rgba16f, binding = 2) uniform writeonly image3D out_py;
layout(rgba16f, binding = 3) uniform writeonly image3D out_ny;
layout(rgba16f, binding = 4) uniform writeonly image3D out_pz;
layout(rgba16f, binding = 5) uniform writeonly image3D out_nz;
layout(rgba16f, binding = 6) uniform writeonly image3D out_columns;  // written by the OCCUPANCY pass only
#ifdef VCT_DEFERRED_GLOSSY
// the six faces' gloss texels (vct_trace.glsl's VCT_GLOSS_READ), side by side along x (face f at x + f R),
// written by the coverage and direct passes: the eighth image, the most some drivers give a compute shader
layout(rgba16f, binding = 7) uniform writeonly image3D out_gloss;
#endif
uniform int cascade;
uniform int inject;     // 0: coverage only; 1: direct radiance; 2: direct + gathered bounce
uniform float lod_min;  // the visibility cones' finest mip
#include "vct_trace.glsl"

vec3 irradiance(vec3 n) {
    vec4 n4 = vec4(n, 1.0);
    return max(vec3(dot(n4, M[0] * n4), dot(n4, M[1] * n4), dot(n4, M[2] * n4)), vec3(0.0));
}

void put(int f, ivec3 q, vec4 value) {
    if (f == 0) imageStore(out_px, q, value);
    else if (f == 1) imageStore(out_nx, q, value);
    else if (f == 2) imageStore(out_py, q, value);
    else if (f == 3) imageStore(out_ny, q, value);
    else if (f == 4) imageStore(out_pz, q, value);
    else imageStore(out_nz, q, value);
}

#ifdef VCT_DEFERRED_GLOSSY
void put_gloss(int f, ivec3 q, vec4 value) {
    imageStore(out_gloss, ivec3(q.x + f * vct_resolution, q.yz), value);
}
#endif

const float PI = 3.14159265358979323846;

// L_g(r): the environment convolved with the normalised Phong lobe of exponent N about r.
// VCT_GLOSSY_ENV (the frame's injection): vct_glossy_env.glsl (on a cube store the broad-lobe table below N = 255,
// else the environment's mip chain at the lobe's level, on the cube the chain weighted by solid angle). SH9 cannot stand in for a narrow lobe: its order-2 projection spreads a bright window
// over the whole sphere (a Phong torus (N = 50) under the Ennis probe, its second bounce traced in numpy: twice
// the radiance of the same bounce under the environment itself).
// Otherwise (a voxel scene made without the frame's environment store: tests) the SH9 radiance convolved
// with the lobe, band factors Lambda_l = (N + 1) int_0^1 t^N P_l(t) dt: 1, (N + 1) / (N + 2), N / (N + 3)
// (scenes/environment/shbasis.py's basis and order).
#ifdef VCT_GLOSSY_ENV
#include "vct_glossy_env.glsl"
vec3 glossy_env(vec3 r, float N) {
    return vct_glossy_env(r, N);
}
#else
vec3 glossy_env(vec3 r, float N) {
    float l1 = (N + 1.0) / (N + 2.0), l2 = N / (N + 3.0);
    float x = r.x, y = r.y, z = r.z;
    float Y[9] = float[9](0.282095, 0.488603 * l1 * y, 0.488603 * l1 * z, 0.488603 * l1 * x,
                          1.092548 * l2 * x * y, 1.092548 * l2 * y * z, 0.315392 * l2 * (3.0 * z * z - 1.0),
                          1.092548 * l2 * x * z, 0.546274 * l2 * (x * x - y * y));
    vec3 L = vec3(0.0);
    for (int k = 0; k < 9; ++k) L += Y[k] * coeffs[k].rgb;
    return max(L, vec3(0.0));
}
#endif

// tan of the glossy cone's half-angle for Phong exponent N, as vct_math.glossy_half_angle: the cone's solid
// angle 2 pi (1 - cos a) is the lobe's 2 pi / (N + 1), so cos a = N / (N + 1), a clamped to
// [GLOSSY_MIN_DEG, GLOSSY_MAX_DEG] (vct_math.GLOSSY_HALF_ANGLE_RANGE)
const float GLOSSY_MIN_DEG = 1.0;
const float GLOSSY_MAX_DEG = 30.0;
float glossy_tan(float N) {
    float a = acos(clamp(N / (N + 1.0), 0.0, 1.0));
    return tan(clamp(a, radians(GLOSSY_MIN_DEG), radians(GLOSSY_MAX_DEG)));
}

// The glossy lobe's light at x (normal n) toward v, mirror direction r: (V_g L_g(r) + L_b, before F ks).
// The lobe reflects int P(l) L_in(l) dl, P the normalised Phong lobe about r and L_in the environment's
// radiance L_env where the voxels leave direction l open (vis(l) = 1), theirs, L_vox, where they block it:
// int P vis L_env + int P (1 - vis) L_vox. Taking L_env under the lobe as uncorrelated with vis, the first
// term is L_g(r) V_g, V_g = int P vis the lobe's unblocked share; a cone along r with the lobe's
// half-angle estimates V_g as 1 - its opacity and the second term as its gathered radiance L_b (the rule
// the shading pass applies to the glossy lobe, vct.glsl). The diffuse cones' cosine-weighted visibility
// is the wrong share for the lobe: where r points at a nearby surface (a torus's inner wall looking
// across the hole) the hemisphere is about half open, and V_d passed half of L_g(r) that the surface
// cannot reflect.
// Returns (L_b, V_g).
vec4 glossy_lobe(vec3 x, vec3 n, vec3 r, float N) {
    float h = vct_local_voxel(x);
    vec4 s = vct_cone(x + vct_normal_voxels * h * n, r, glossy_tan(N), vct_start_voxels * h, lod_min, x, n);
    return vec4(inject == 2 ? s.rgb : vec3(0.0), 1.0 - s.a);
}

// The voxel's opacity along each axis: the fraction of the voxel's cross-section its surface covers seen
// along that axis. A plane of unit normal n crossing a voxel of edge h is a graph over the faces of its
// dominant axis m (|n_m| = |n|_inf): its piece inside the voxel has area about h^2 / |n_m| and projects
// along axis a onto h^2 |n_a| / |n_m| of the voxel's face, so alpha_a = |n_a| / |n|_inf: 1 along the
// normal, 0 along a plane's own directions (a wall running alongside a cone does not block it, where a
// voxel opaque along every axis blocks the cone once per texel it passes). Several surfaces in a voxel
// (a corner, a thin wall's two sides): each axis keeps the largest of their coverages.
vec3 coverage(int v) {
    vec3 cover = vec3(0.0);
    for (int f = 0; f < 6; ++f) {
        int o = FACE_INTS0 + 4 * f;
        vec3 ns = vec3(voxel_sum(v, o + 1), voxel_sum(v, o + 2), voxel_sum(v, o + 3));
        vec3 m = abs(ns);
        float top = max(m.x, max(m.y, m.z));
        if (voxel_sum(v, o) > 0 && top > 0.0) cover = max(cover, m / top);
    }
    return cover;
}

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    int R = vct_resolution;
    if (any(greaterThanEqual(g, ivec3(R)))) return;
    int v = (g.z * R + g.y) * R + g.x;
    int count = voxel_sum(v, 0);
    ivec3 q = ivec3(g.xy, g.z + cascade * R);
    vec3 cover = coverage(v);
    if (count == 0 || inject == 0) {
        for (int f = 0; f < 6; ++f) put(f, q, vec4(0.0, 0.0, 0.0, count > 0 ? cover[f / 2] : 0.0));
        if (inject == 0) imageStore(out_columns, q, vec4(count > 0 ? cover : vec3(0.0), 0.0));
#ifdef VCT_DEFERRED_GLOSSY
        if (inject <= 1)
            for (int f = 0; f < 6; ++f) put_gloss(f, q, vec4(0.0));
#endif
        return;
    }
    float cnt = float(count);
    vec3 kd = vec3(voxel_sum(v, 1), voxel_sum(v, 2), voxel_sum(v, 3)) / (ALBEDO_SCALE * cnt);
    vec3 ks = vec3(voxel_sum(v, 4), voxel_sum(v, 5), voxel_sum(v, 6)) / (ALBEDO_SCALE * cnt);
    float N = float(voxel_sum(v, 7)) / (EXPONENT_SCALE * cnt);
    float f0 = float(voxel_sum(v, 8)) / (ALBEDO_SCALE * cnt);
    float schlick = float(voxel_sum(v, 9)) / (ALBEDO_SCALE * cnt);
    float he = vct_half_extent * exp2(float(cascade));
    float h = 2.0 * he / float(R);
    vec3 x = vct_centre - vec3(he) + (vec3(g) + 0.5) * h;
    // a term's cones are traced only where the material has that term: the diffuse cones where kd > 0 and
    // F < 1 somewhere (f0 < 1), the glossy cone where ks > 0 and F > 0 somewhere (f0 > 0 or Schlick's)
    bool diffuse = any(greaterThan(kd, vec3(0.0))) && f0 < 1.0;
    bool glossy = any(greaterThan(ks, vec3(0.0))) && (f0 > 0.0 || schlick > 0.0);
    // faces whose mean normals agree (a flat surface: up to three faces share one normal) share one set
    // of diffuse cones: at most six sets, usually one, two for a thin wall's two sides; the glossy cone
    // is one per face (its mirror direction is the face's own)
    vec3 done_n[6];
    vec4 done_E[6];  // (environment irradiance x V_d + bounce, V_d)
    int done = 0;
    vec3 L[6];
    vec3 G[6];  // VCT_DEFERRED_GLOSSY: the glossy lobe's weight F ks V_g toward each face
    bool faced[6];
    for (int f = 0; f < 6; ++f) {
        int o = FACE_INTS0 + 4 * f;
        vec3 ns = vec3(voxel_sum(v, o + 1), voxel_sum(v, o + 2), voxel_sum(v, o + 3));
        faced[f] = voxel_sum(v, o) > 0 && length(ns) > 0.0;
        L[f] = vec3(0.0);
        G[f] = vec3(0.0);
        if (!faced[f]) continue;
        vec3 n = normalize(ns);
        vec3 a = vec3(0.0);
        a[f / 2] = (f % 2 == 0) ? 1.0 : -1.0;
        float c = max(dot(n, a), 0.0);
        float F = f0 + schlick * (1.0 - f0) * pow(max(1.0 - c, 0.0), 5.0);  // pow of a negative base is undefined
        if (diffuse) {
            int k = 0;
            for (; k < done; ++k)
                if (dot(done_n[k], n) > SAME_NORMAL_COS) break;
            if (k == done) {
                vec4 gathered = vct_diffuse(x, n, lod_min);
                done_n[done] = n;
                done_E[done] = vec4(irradiance(n) * gathered.a + (inject == 2 ? gathered.rgb : vec3(0.0)),
                                    gathered.a);
                ++done;
            }
            L[f] += (1.0 - F) * kd / PI * done_E[k].rgb;
        }
        if (glossy) {
            vec3 r = reflect(-a, n);
            vec4 lobe = glossy_lobe(x, n, r, N);
#ifdef VCT_DEFERRED_GLOSSY
            // the environment's part is left to the read, toward the cone that reads the face (vct_trace.glsl's
            // vct_gloss_radiance): the face keeps the gathered bounce, its gloss texel the lobe's weight
            L[f] += F * ks * vct_lobe_above(c, N) * lobe.rgb;
            G[f] = F * ks * lobe.a;
#else
            L[f] += F * ks * vct_lobe_above(c, N) * (glossy_env(r, N) * lobe.a + lobe.rgb);
#endif
        }
    }
    for (int f = 0; f < 6; ++f) {
        // premultiplied: the radiance of what covers the face's axis, times that coverage (and the radiance scale)
        put(f, q, cover[f / 2] * vec4(L[f] * vct_radiance_scale, 1.0));
#ifdef VCT_DEFERRED_GLOSSY
        // the lobe's weight F ks V_g and its exponent (weighted by the weight's mean, so that the mips' means
        // divide back to a weighted mean exponent), premultiplied as the radiance is; the bounce passes leave it
        if (inject == 1) put_gloss(f, q, cover[f / 2] * vec4(G[f], N * (G[f].r + G[f].g + G[f].b) / 3.0));
#endif
    }
}
