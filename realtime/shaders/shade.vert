#version 430
// Meshes arrive in world space (transformed once in numpy, shared with the reference).
in vec3 in_position;
in vec3 in_normal;
uniform mat4 view_proj;
out vec3 v_position;
out vec3 v_normal;
#ifdef REFLECTION_PER_VERTEX
// realtime.reflection = "per_vertex": the mirror direction computed at the vertices and interpolated
// across each triangle (the fixed-function way), instead of per pixel from the interpolated normal.
uniform vec3 camera_position;
out vec3 v_reflect;
#endif
#ifdef DIFFUSE_PRT
// Precomputed radiance transfer (realtime/prt.py): per vertex, E_c = sum_k L_{k,c} T_{v,k,c}: the
// environment's SH coefficients (this frame's projection, sh_project_n.comp) dotted with the vertex's
// transfer vector (precomputed, one per colour channel). The whole per-frame cost of PRT is this dot.
layout(std430, binding = 2) readonly buffer SHN { vec4 coeffs[SH_COUNT]; vec4 weighted[SH_COUNT]; };
layout(std430, binding = 7) readonly buffer Transfer { float transfer[]; };  // (V, SH_COUNT, 3)
out vec3 v_irradiance;
#endif
void main() {
    v_position = in_position;
#ifdef DIFFUSE_PRT
    int base = gl_VertexID * SH_COUNT * 3;  // indexed draws: gl_VertexID is the vertex's index
    vec3 E = vec3(0.0);
    for (int k = 0; k < SH_COUNT; ++k)
        E += coeffs[k].rgb * vec3(transfer[base + 3 * k], transfer[base + 3 * k + 1], transfer[base + 3 * k + 2]);
    v_irradiance = E;
#endif
    v_normal = in_normal;
#ifdef REFLECTION_PER_VERTEX
    float len = length(in_normal);
    vec3 n = len > 0.0 ? in_normal / len : vec3(0.0, 1.0, 0.0);
    v_reflect = reflect(-normalize(camera_position - in_position), n);
#endif
    gl_Position = view_proj * vec4(in_position, 1.0);
}
