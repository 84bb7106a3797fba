#version 430
// Fill the base level of the cube map: each texel gets the environment's radiance along its
// world direction (turned by the environment's rotation about +Y).
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 0) uniform writeonly imageCube dst;
uniform sampler2D env;
uniform mat3 world_to_env;  // inverse of the environment's to_world rotation
uniform int size;
#include "common.glsl"

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (g.x >= size || g.y >= size) return;
    float sc = 2.0 * (float(g.x) + 0.5) / float(size) - 1.0;
    float tc = 2.0 * (float(g.y) + 0.5) / float(size) - 1.0;  // row g.y is t
    vec3 d = face_direction(g.z, sc, tc);
    imageStore(dst, g, vec4(env_lookup(env, world_to_env * normalize(d)), 1.0));
}
