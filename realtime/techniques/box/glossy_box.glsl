#ifdef GLOSSY_BOX
// The paper's glossy term: the 2x2-box chain read at a LOD computed on the host per object
// (realtime.levels.glossy_lod: level(s) + offset(N) + lod_bias, clamped to the chain).
#if defined(ENV_DUAL_PARABOLOID) || defined(ENV_SPHERE_MAP)
// A 2D parameterization of the environment (realtime/engine/environment_maps.py): the host's LOD, unclamped,
// becomes the level of equal solid angle under the lookup (env_map.glsl).
#include "env_map.glsl"
uniform float glossy_lod;

vec3 glossy_radiance(vec3 r) {
    return env_map_radiance(r, glossy_lod);
}
#else
uniform samplerCube env_cube;
uniform float glossy_lod;

vec3 glossy_radiance(vec3 r) {
    return textureLod(env_cube, r, glossy_lod).rgb;
}
#endif
#endif
