#version 430
// The environment seen behind the objects (alpha 0: not covered, masked out of metrics).
in vec2 v_ndc;
uniform sampler2D env;
uniform mat4 inv_view_proj;
uniform mat3 world_to_env;
out vec4 frag;
#include "common.glsl"

void main() {
    vec4 far_point = inv_view_proj * vec4(v_ndc, 1.0, 1.0);
    vec4 near_point = inv_view_proj * vec4(v_ndc, -1.0, 1.0);
    vec3 d = normalize(far_point.xyz / far_point.w - near_point.xyz / near_point.w);
    frag = vec4(env_lookup(env, world_to_env * d), 0.0);
}
