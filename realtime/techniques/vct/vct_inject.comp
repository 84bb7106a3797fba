#version 430
// Per voxel of one cascade (realtime/techniques/vct/vct.py), level 0 of the six face textures.
// OCCUPANCY pass: alpha = 1 where a triangle touched the voxel, rgb = 0 (the opacity the visibility
// cones of the INJECT pass trace through, after its mips are built).
// INJECT pass: each face f that some triangle faces (weight W_f = sum max(0, n . a_f) > 0) gets the
// direct radiance leaving toward a_f, normal-weighted: (W_f / max_g W_g) * albedo / pi * (E(n_f) V(n_f)
// + E_bounce(n_f)), n_f the face's weighted mean normal, E the environment's SH9 irradiance (the
// scene's diffuse technique's M when it is SH9), V the diffuse cones' visibility through the voxels
// themselves (mips >= 1 only: level 0 is being written), E_bounce what the same cones gather from the
// previous bounce's voxels (BOUNCE: radiance already in the mips).
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(std430, binding = 1) readonly buffer Voxels { int acc[]; };
layout(std430, binding = 2) readonly buffer SH { mat4 M[3]; vec4 coeffs[9]; };
layout(rgba16f, binding = 0) uniform writeonly image3D out_px;
layout(rgba16f, binding = 1) uniform writeonly image3D out_nx;
layout(rgba16f, binding = 2) uniform writeonly image3D out_py;
layout(rgba16f, binding = 3) uniform writeonly image3D out_ny;
layout(rgba16f, binding = 4) uniform writeonly image3D out_pz;
layout(rgba16f, binding = 5) uniform writeonly image3D out_nz;
uniform int cascade;
uniform int inject;     // 0: occupancy only; 1: direct radiance; 2: direct + gathered bounce
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

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    int R = vct_resolution;
    if (any(greaterThanEqual(g, ivec3(R)))) return;
    int base = ((g.z * R + g.y) * R + g.x) * VOXEL_INTS;
    int count = acc[base];
    ivec3 q = ivec3(g.xy, g.z + cascade * R);
    if (count == 0 || inject == 0) {
        vec4 v = vec4(0.0, 0.0, 0.0, count > 0 ? 1.0 : 0.0);
        for (int f = 0; f < 6; ++f) put(f, q, v);
        return;
    }
    vec3 albedo = vec3(acc[base + 1], acc[base + 2], acc[base + 3]) / (ALBEDO_SCALE * float(count));
    float he = vct_half_extent * exp2(float(cascade));
    float h = 2.0 * he / float(R);
    vec3 x = vct_centre - vec3(he) + (vec3(g) + 0.5) * h;
    // faces whose mean normals agree (a flat surface: up to three faces share one normal) share one set
    // of cones: at most six sets, usually one, two for a thin wall's two sides
    // normal-weighted faces, normalised by the voxel's most-faced direction: a flat surface seen along
    // its normal reads its full radiance (sum_a n_a^2 w_a = 1 for an axis-aligned or diagonal normal)
    float W_max = 0.0;
    for (int f = 0; f < 6; ++f) W_max = max(W_max, float(acc[base + 4 + 4 * f]));
    vec3 done_n[6];
    vec3 done_E[6];
    int done = 0;
    for (int f = 0; f < 6; ++f) {
        int o = base + 4 + 4 * f;
        float W = float(acc[o]) / NORMAL_SCALE;
        vec3 L = vec3(0.0);
        vec3 ns = vec3(acc[o + 1], acc[o + 2], acc[o + 3]);
        if (W > 0.0 && length(ns) > 0.0) {
            vec3 n = normalize(ns);
            int k = 0;
            for (; k < done; ++k)
                if (dot(done_n[k], n) > SAME_NORMAL_COS) break;
            if (k == done) {
                vec4 gathered = vct_diffuse(x, n, lod_min);
                vec3 E = irradiance(n) * gathered.a;
                if (inject == 2) E += gathered.rgb;
                done_n[done] = n;
                done_E[done] = E;
                ++done;
            }
            L = (W * NORMAL_SCALE / W_max) * albedo / 3.14159265358979323846 * done_E[k];
        }
        put(f, q, vec4(L, 1.0));
    }
}
