#ifdef GLOSSY_BOX
// The paper's glossy term: the 2x2-box chain read at a LOD computed on the host per object
// (realtime.levels.glossy_lod: level(s) + offset(N) + lod_bias, clamped to the chain).
uniform samplerCube env_cube;
uniform float glossy_lod;

vec3 glossy_radiance(vec3 r) {
    return textureLod(env_cube, r, glossy_lod).rgb;
}
#endif
