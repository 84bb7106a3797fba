// L_g(r, N): the environment convolved with the normalised Phong lobe of exponent N about r,
// (N + 1) / (2 pi) int L(w) max(r . w, 0)^N dw. The injection reads it for the glossy lobe it stores
// (vct_inject.comp); the deferred glossy read (VCT_GLOSS_READ, vct_trace.glsl) reads it toward each cone, broadened
// to a few units of N on the diffuse cones. Included once per shader.
// - On a cube store (VCT_LOBE_TABLE): the lobe's integral tabulated for N = 2^j - 1, j = 0..7
//   (lobe_table.py), read as a cubic in j = log2(N + 1) through the four layers around it; above the top layer
//   (127) blended into the chain over one octave, the chain alone from 255. A chain's texel is a box mean, not
//   the lobe: its read misses the lobe's integral by 13-90 % RMS of the mean radiance for N = 0-50 on the
//   probes, the table's by at most 3 % up to 50 (benchmarks/vct_lobe_table.py).
// - The chain (vct_chain_env; a 2D store always): the environment's mip chain (on the cube the chain weighted by
//   solid angle; a 2D parameterization's own through env_map.glsl) at the level whose texel covers the lobe's
//   solid angle (McGuire et al. 2013, realtime.engine.levels.mcguire_offset): the lobe's normalisation makes it
//   worth 2 pi / (N + 1) sr, a cube texel at level l covers about 4 pi / (6 (base / 2^l)^2), so
//   l = log2(base sqrt(3)) - 0.5 log2(N + 1).
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

vec3 vct_chain_env(vec3 r, float N) {
    return max(vct_env_lookup(r, log2(vct_env_base_size * sqrt(3.0)) - 0.5 * log2(N + 1.0)), vec3(0.0));
}

#ifdef VCT_LOBE_TABLE
// Each layer is a smooth function of N (the lobe's SH band factors are rational in N), so the read is a cubic in
// j = log2(N + 1) through the four layers around it (Lagrange weights at nodes -1, 0, 1, 2): it passes through every
// layer, so it is continuous where j crosses one and the four change. Linear interpolation had missed by 4-6 % RMS
// at N = 2-4 under Ennis, between layers; a quadratic through the nearest three jumped by up to 1.7 % where the
// nearest three change. Bilinear in the axis (vct_lobe_axis.glsl's grid; the table has no mips).
#include "vct_lobe_axis.glsl"
uniform sampler3D vct_lobe_table;
#ifndef VCT_LOBE_LAYERS
#error "VCT_LOBE_TABLE needs VCT_LOBE_LAYERS (lobe_table.defines)"
#endif

vec3 vct_lobe_layer(vec2 uv, float layer) {
    return textureLod(vct_lobe_table, vec3(uv, (layer + 0.5) / VCT_LOBE_LAYERS), 0.0).rgb;
}

vec3 vct_glossy_env(vec3 r, float N) {
    float j = log2(max(N, 0.0) + 1.0);
    float past = clamp(j - (VCT_LOBE_LAYERS - 1.0), 0.0, 1.0);  // 0 up to the top layer, 1 an octave above it
    vec3 table = vec3(0.0);
    if (past < 1.0) {
        float m = clamp(floor(j), 1.0, VCT_LOBE_LAYERS - 3.0), x = min(j, VCT_LOBE_LAYERS - 1.0) - m;
        vec2 uv = vct_lobe_uv(r);
        table = max(-x * (x - 1.0) * (x - 2.0) / 6.0 * vct_lobe_layer(uv, m - 1.0)
                    + (x + 1.0) * (x - 1.0) * (x - 2.0) / 2.0 * vct_lobe_layer(uv, m)
                    - (x + 1.0) * x * (x - 2.0) / 2.0 * vct_lobe_layer(uv, m + 1.0)
                    + (x + 1.0) * x * (x - 1.0) / 6.0 * vct_lobe_layer(uv, m + 2.0), vec3(0.0));
    }
    return past > 0.0 ? mix(table, vct_chain_env(r, N), past) : table;
}
#else
vec3 vct_glossy_env(vec3 r, float N) {
    return vct_chain_env(r, N);
}
#endif
#endif
