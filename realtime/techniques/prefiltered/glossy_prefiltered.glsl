#ifdef GLOSSY_PREFILTERED
// The chain prefiltered with this object's Phong lobe (realtime/techniques/prefiltered/prefilter.py), read at the level
// the host chose for its exponent.
uniform samplerCube prefiltered_cube;
uniform float prefiltered_lod;

vec3 glossy_radiance(vec3 r) {
    return textureLod(prefiltered_cube, r, prefiltered_lod).rgb;
}
#endif
