// The environment stored as a 2D parameterization (realtime/engine/environment_maps.py), read by the glossy
// lookup: ENV_DUAL_PARABOLOID (two maps in a texture array, world-fixed frame) or ENV_SPHERE_MAP (one
// map, the capture view's eye space); mirrors scenes/environment/paraboloid.py and scenes/environment/spheremap.py.
// The LOD rule is in solid angle, so that a LOD means the same blur on every parameterization: the
// host's LOD is a level of the cube map (whose mean texel at level l covers Omega_ref 4^l, Omega_ref =
// 4 pi / (6 base^2)); here the texel under the lookup covers dOmega/dA(p) A0 4^l (A0: the plane area
// of a level-0 texel), so the level of equal solid angle is
//     lod + 0.5 log2(Omega_ref / A0) - 0.5 log2(dOmega/dA(p)) = lod + ENV_LOD_OFFSET - 0.5 log2(density)
// clamped to the chain [0, ENV_MAX_LOD]. ENV_LOD_OFFSET and ENV_MAX_LOD are #defined by the host.
// included once per shader (the glossy box and voxel cone tracing's deferred glossy read may both need it)
#ifndef ENV_MAP_GLSL
#define ENV_MAP_GLSL
uniform sampler2DArray env_map;
uniform mat3 env_frame;  // world -> the map's frame

// (plane position x, y in the unit disc, layer, dOmega/dA there) of a unit direction in the map's frame
vec4 env_map_position(vec3 d) {
#ifdef ENV_DUAL_PARABOLOID
    vec2 p = d.xy / (1.0 + abs(d.z));
    float q = 1.0 + dot(p, p);
    return vec4(p, d.z >= 0.0 ? 0.0 : 1.0, 4.0 / (q * q));
#else
    float len = length(vec3(d.xy, d.z + 1.0));  // 0 only straight behind the ball: the rim
    return vec4(len > 0.0 ? d.xy / len : vec2(1.0, 0.0), 0.0, 4.0);
#endif
}

vec3 env_map_radiance(vec3 r, float lod) {
    vec4 m = env_map_position(env_frame * normalize(r));
    float level = clamp(lod + ENV_LOD_OFFSET - 0.5 * log2(m.w), 0.0, ENV_MAX_LOD);
    return textureLod(env_map, vec3(0.5 * m.xy + 0.5, m.z), level).rgb;
}
#endif
