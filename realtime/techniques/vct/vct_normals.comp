#version 430
// Per voxel of one cascade (realtime/techniques/vct/vct.py), level 0 of the six face-normal textures: face f
// holds the mean normal n of the voxel's surfaces that face its direction a_f (the voxeliser's weighted sum
// of max(0, n . a_f) n, normalised), 0 where none does (stored as vct_normal_bytes.glsl says). The injection
// lights face f with that surface's radiance toward a_f; a cone reading the face learns from the normal
// whether the surface also faces the cone as a whole (n . d < 0), which the face's own axis cannot tell
// (vct_trace.glsl's vct_read). A sum of vectors each with n . a_f > 0 keeps n . a_f > 0, so a stored normal
// always leans toward its face. Alpha: how far those normals spread (vct_normal_bytes.glsl).
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
#include "vct_voxel_sums.glsl"
layout(rgba8, binding = 0) uniform writeonly image3D out_px;
layout(rgba8, binding = 1) uniform writeonly image3D out_nx;
layout(rgba8, binding = 2) uniform writeonly image3D out_py;
layout(rgba8, binding = 3) uniform writeonly image3D out_ny;
layout(rgba8, binding = 4) uniform writeonly image3D out_pz;
layout(rgba8, binding = 5) uniform writeonly image3D out_nz;
uniform int cascade;
uniform int resolution;
#include "vct_normal_bytes.glsl"

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
    int R = resolution;
    if (any(greaterThanEqual(g, ivec3(R)))) return;
    int v = (g.z * R + g.y) * R + g.x;
    ivec3 q = ivec3(g.xy, g.z + cascade * R);
    for (int f = 0; f < 6; ++f) {
        int o = FACE_INTS0 + 4 * f;
        vec3 ns = vec3(voxel_sum(v, o + 1), voxel_sum(v, o + 2), voxel_sum(v, o + 3));
        bool faced = voxel_sum(v, 0) > 0 && voxel_sum(v, o) > 0 && length(ns) > 0.0;
        // The spread: the length of the weighted mean of the unit normals, sum w n / sum w, is |ns| over the
        // weights' sum (both in the same fixed point). Each triangle's sums are rounded to integers apart, which
        // moves |ns| by up to sqrt(3) / 2 and the weights' sum by up to 1 / 2 per triangle: a tilted plane would
        // read 1 - l up to (sqrt(3) / 2 + 1 / 2) k / sum w for k triangles (2e-4 for one at normal (0.6, 0.8, 0)).
        // That much is rounding, not spread: l is raised by it (at most to 1).
        float weights = float(voxel_sum(v, o));
        float rounding = (0.5 * sqrt(3.0) + 0.5) * float(voxel_sum(v, 0)) / max(weights, 1.0);
        float mean_length = faced ? min(length(ns) / weights + rounding, 1.0) : 1.0;
        put(f, q, vct_normal_encoded(faced ? normalize(ns) : vec3(0.0), mean_length));
    }
}
