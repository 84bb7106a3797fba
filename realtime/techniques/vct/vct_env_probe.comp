#version 430
// Test probe (realtime/techniques/vct/vct.py VoxelScene.read_environment): the environment as the glossy reads take
// it (vct_glossy_env.glsl, bound by VoxelScene.bind_environment: the broad-lobe table and the chain, or without
// VCT_LOBE_TABLE the chain alone): L_g along each direction for each Phong exponent.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Reads { vec4 reads[]; };  // (direction, exponent)
layout(std430, binding = 1) writeonly buffer Result { vec4 result[]; };
uniform int count;
#include "vct_glossy_env.glsl"

void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i >= count) return;
    result[i] = vec4(vct_glossy_env(normalize(reads[i].xyz), reads[i].w), 0.0);
}
