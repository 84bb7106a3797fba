#version 430
// Fill the base level of a 2D environment parameterization (dual paraboloid: 2 layers, sphere map:
// 1; realtime/engine/environment_maps.py): each texel gets the environment's radiance along its world
// direction, the environment turned about +Y by u_shift = rotation_deg / 360 (env_to_cube.comp's rule).
// Each texel's (u, v) is computed once in float64 (texel_uv, one layer per layer of dst).
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 0) uniform writeonly image2DArray dst;
uniform sampler2D env;
uniform sampler2DArray texel_uv;  // (size, size, layers): u, v of each texel's world direction
uniform float u_shift;
uniform int size;
#include "common.glsl"

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (g.x >= size || g.y >= size) return;
    vec2 uv = texelFetch(texel_uv, g, 0).rg;
    imageStore(dst, g, vec4(env_lookup_uv(env, uv.x + u_shift, uv.y), 1.0));
}
