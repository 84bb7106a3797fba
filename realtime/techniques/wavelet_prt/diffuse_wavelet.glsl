#ifdef DIFFUSE_WAVELET_PRT
// Wavelet PRT (wavelet_prt.py): the irradiance was summed per vertex (wavelet_dot.comp) and arrives interpolated.
// The transfer is that of the vertex's own (front) normal.
in vec3 v_irradiance;

vec3 diffuse_irradiance(vec3 n) {
    return v_irradiance;
}
#endif
