#ifdef DIFFUSE_PRT
// Precomputed radiance transfer (prt.py): per vertex, E_c = sum_k L_{k,c} T_{v,k,c}: the
// environment's SH coefficients (this frame's projection, sh_project_n.comp) dotted with the vertex's
// transfer vector (precomputed, one per colour channel). The whole per-frame cost of PRT is this dot.
// The transfer is read from an SSBO by gl_VertexID, not from vertex attributes: at order 8 it is
// 81 x 3 floats per vertex (972 bytes), far beyond GL_MAX_VERTEX_ATTRIBS (16 vec4 at least).
layout(std430, binding = 2) readonly buffer SHN { vec4 coeffs[SH_COUNT]; vec4 weighted[SH_COUNT]; };
layout(std430, binding = 7) readonly buffer Transfer { float transfer[]; };  // (V, SH_COUNT, 3)
out vec3 v_irradiance;

void prt_vertex() {
    int base = gl_VertexID * SH_COUNT * 3;  // indexed draws: gl_VertexID is the vertex's index
    vec3 E = vec3(0.0);
    for (int k = 0; k < SH_COUNT; ++k)
        E += coeffs[k].rgb * vec3(transfer[base + 3 * k], transfer[base + 3 * k + 1], transfer[base + 3 * k + 2]);
    v_irradiance = E;
}
#endif
