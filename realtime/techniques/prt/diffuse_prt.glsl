#ifdef DIFFUSE_PRT
// Precomputed radiance transfer (realtime/techniques/prt/prt.py): the irradiance E = sum_k L_k T_k was dotted per
// vertex in shade.vert (the environment's SH coefficients L with the vertex's transfer vector T) and
// arrives interpolated. The transfer is that of the vertex's own (front) normal.
in vec3 v_irradiance;

vec3 diffuse_irradiance(vec3 n) {
    return v_irradiance;
}
#endif
