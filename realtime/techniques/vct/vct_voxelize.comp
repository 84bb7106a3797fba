#version 430
// Voxelisation of the scene's triangles into one cascade (realtime/techniques/vct/vct.py): one invocation per
// triangle visits the voxels of its bounding box and keeps those the triangle overlaps (the
// separating-axis triangle/box test of Akenine-Moller 2001: conservative). Per voxel, integer atomics
// accumulate: the triangle count, the reflectance (kd, ks, exponent, f0, Schlick flag: summed, the injection
// divides by the count), and for each of the six face directions a_f the
// normal weight sum max(0, n . a_f) and the weighted normal sum max(0, n . a_f) n (a thin or folded
// surface keeps both of its sides apart instead of averaging them to nothing). Two-sided triangles
// count with both n and -n.
layout(local_size_x = 64) in;
// per triangle: p0 p1 p2 (n, two_sided + 2 schlick) (kd, f0) (ks, exponent)
layout(std430, binding = 0) readonly buffer Triangles { vec4 tri[]; };
#define VCT_SUMS_ATOMIC
#include "vct_voxel_sums.glsl"
uniform int triangle_count;
uniform vec3 grid_min;   // the cascade's lower corner
uniform float voxel;     // its voxel edge
uniform int resolution;

bool axis_test(vec3 axis, vec3 v0, vec3 v1, vec3 v2, vec3 half_size) {
    float p0 = dot(v0, axis), p1 = dot(v1, axis), p2 = dot(v2, axis);
    float r = dot(half_size, abs(axis));
    return !(min(p0, min(p1, p2)) > r || max(p0, max(p1, p2)) < -r);
}

bool overlaps(vec3 c, vec3 hs, vec3 a, vec3 b, vec3 d) {
    vec3 v0 = a - c, v1 = b - c, v2 = d - c;
    vec3 e0 = v1 - v0, e1 = v2 - v1, e2 = v0 - v2;
    vec3 n = cross(e0, e1);
    if (abs(dot(n, v0)) > dot(hs, abs(n))) return false;
    vec3 axes[3] = vec3[3](vec3(1, 0, 0), vec3(0, 1, 0), vec3(0, 0, 1));
    vec3 edges[3] = vec3[3](e0, e1, e2);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            vec3 ax = cross(axes[i], edges[j]);
            if (dot(ax, ax) > 1e-20 && !axis_test(ax, v0, v1, v2, hs)) return false;
        }
    return true;  // the box axes are the bounding-box test the caller did
}

void add(int v, vec3 n) {
    const float S = NORMAL_SCALE;
    for (int f = 0; f < 6; ++f) {
        vec3 a = vec3(0.0);
        a[f / 2] = (f % 2 == 0) ? 1.0 : -1.0;
        float w = max(dot(n, a), 0.0);
        // a branch, not `continue`: with `continue` here Mesa llvmpipe dropped one voxel's +Y face sums of a
        // tilted plane (tests/realtime/test_vct_gpu.py's tilted-plane test), the other faces and the count kept
        if (w > 0.0) {
            int o = FACE_INTS0 + 4 * f;
            voxel_sum_add(v, o, int(round(w * S)));
            voxel_sum_add(v, o + 1, int(round(w * n.x * S)));
            voxel_sum_add(v, o + 2, int(round(w * n.y * S)));
            voxel_sum_add(v, o + 3, int(round(w * n.z * S)));
        }
    }
}

void main() {
    int t = int(gl_GlobalInvocationID.x);
    if (t >= triangle_count) return;
    vec3 a = tri[6 * t].xyz, b = tri[6 * t + 1].xyz, d = tri[6 * t + 2].xyz;
    vec4 nn = tri[6 * t + 3];
    vec4 kd = tri[6 * t + 4], ks = tri[6 * t + 5];
    bool two_sided = mod(nn.w, 2.0) > 0.5;
    float schlick = nn.w > 1.5 ? 1.0 : 0.0;
    vec3 lo = (min(a, min(b, d)) - grid_min) / voxel;
    vec3 hi = (max(a, max(b, d)) - grid_min) / voxel;
    // the bounding box's voxels, widened by a thousandth of a voxel: a triangle lying on a voxel boundary
    // (lo = hi = an integer, up to rounding) touches the voxels on both sides, and rounding may put the
    // floor in the one below while the separating-axis test rejects it (the plane a hair outside its box)
    ivec3 i0 = max(ivec3(floor(lo - 1e-3)), ivec3(0));
    ivec3 i1 = min(ivec3(floor(hi + 1e-3)), ivec3(resolution - 1));
    if (any(lessThan(i1, i0))) return;
    vec3 hs = vec3(0.5 * voxel);
    for (int z = i0.z; z <= i1.z; ++z)
        for (int y = i0.y; y <= i1.y; ++y)
            for (int x = i0.x; x <= i1.x; ++x) {
                vec3 c = grid_min + (vec3(x, y, z) + 0.5) * voxel;
                if (!overlaps(c, hs, a, b, d)) continue;
                int v = (z * resolution + y) * resolution + x;
                voxel_sum_add(v, 0, 1);
                for (int k = 0; k < 3; ++k) {
                    voxel_sum_add(v, 1 + k, int(round(kd[k] * ALBEDO_SCALE)));
                    voxel_sum_add(v, 4 + k, int(round(ks[k] * ALBEDO_SCALE)));
                }
                voxel_sum_add(v, 7, int(round(ks.w * EXPONENT_SCALE)));
                voxel_sum_add(v, 8, int(round(kd.w * ALBEDO_SCALE)));
                voxel_sum_add(v, 9, int(round(schlick * ALBEDO_SCALE)));
                add(v, nn.xyz);
                if (two_sided) add(v, -nn.xyz);
            }
}
