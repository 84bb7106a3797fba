// L_g(r): the environment convolved with the normalised Phong lobe of exponent N about r, read from the frame's
// environment store (the cube's chain weighted by solid angle, or a 2D parameterization's own chain through
// env_map.glsl) at the level whose texel covers the lobe's solid angle (McGuire et al. 2013,
// realtime.engine.levels.mcguire_offset).
// The lobe's normalisation (N + 1) / (2 pi) makes it worth 2 pi / (N + 1) sr, a cube texel at level l covers
// about 4 pi / (6 (base / 2^l)^2), so l = log2(base sqrt(3)) - 0.5 log2(N + 1). The injection reads it for the
// glossy lobe it stores (vct_inject.comp); the deferred glossy read (VCT_GLOSS_READ, vct_trace.glsl) reads
// it toward each cone. Included once per shader.
#ifndef VCT_GLOSSY_ENV_GLSL
#define VCT_GLOSSY_ENV_GLSL
uniform float vct_env_base_size;  // the cube's level-0 face size (a 2D store's cube-equivalent budget)
#if defined(ENV_DUAL_PARABOLOID) || defined(ENV_SPHERE_MAP)
#include "env_map.glsl"
// the host's LOD unclamped: env_map.glsl turns it into its own level of equal solid angle and clamps that
vec3 vct_env_lookup(vec3 r, float lod) {
    return env_map_radiance(r, lod);
}
#else
// the cube's chain weighted by solid angle (realtime/engine/gpu.py's EnvironmentFilter.solid_angle_chain): texels
// (radiance x w, w), so that rgb / a is the mean radiance over the solid angle the lookup blends
uniform samplerCube vct_env_cube;
vec3 vct_env_lookup(vec3 r, float lod) {
    vec4 t = textureLod(vct_env_cube, r, clamp(lod, 0.0, log2(vct_env_base_size)));
    return t.rgb / max(t.a, 1e-30);
}
#endif

vec3 vct_glossy_env(vec3 r, float N) {
    return max(vct_env_lookup(r, log2(vct_env_base_size * sqrt(3.0)) - 0.5 * log2(N + 1.0)), vec3(0.0));
}
#endif
