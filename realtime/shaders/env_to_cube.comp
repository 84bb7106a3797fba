#version 430
// Fill the base level of the cube map: each texel gets the environment's radiance along its
// world direction, the environment turned by `rotation_deg` about +Y.
// A turn about +Y only shifts the map's u (u_env = u_world + deg / 360, v unchanged), so each
// texel's (u, v) is computed once in float64 (texel_uv, one layer per face) and a frame costs
// a shift and four fetches.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 0) uniform writeonly imageCube dst;
uniform sampler2D env;
uniform sampler2DArray texel_uv;  // (size, size, 6 layers): u, v of each texel's world direction
uniform float u_shift;       // rotation_deg / 360
uniform int size;
#include "common.glsl"

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (g.x >= size || g.y >= size) return;
    vec2 uv = texelFetch(texel_uv, g, 0).rg;
    imageStore(dst, g, vec4(env_lookup_uv(env, uv.x + u_shift, uv.y), 1.0));
}
