#ifdef DIFFUSE_IRRADIANCE_MAP
// The exact cosine convolution of the environment, stored by normal (realtime/techniques/irradiance_map/irradiance_convolution.py).
uniform samplerCube irradiance_cube;

vec3 diffuse_irradiance(vec3 n) {
    return textureLod(irradiance_cube, n, 0.0).rgb;
}
#endif
