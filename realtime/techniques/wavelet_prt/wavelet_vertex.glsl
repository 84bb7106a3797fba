#ifdef DIFFUSE_WAVELET_PRT
// Wavelet PRT (wavelet_prt.py): the vertex's irradiance E, summed this frame by wavelet_dot.comp from the K kept
// lighting coefficients and the vertex's sparse wavelet transfer, read by gl_VertexID (indexed draws: the
// vertex's index) and interpolated across the triangle.
layout(std430, binding = 7) readonly buffer WaveletIrradiance { vec4 wavelet_irradiance[]; };
out vec3 v_irradiance;

void wavelet_vertex() {
    v_irradiance = wavelet_irradiance[gl_VertexID].rgb;
}
#endif
