#version 430
// Test and measurement probe (realtime/techniques/vct/vct.py VoxelScene.probe): the diffuse cones at given points and
// normals, as the shading pass traces them: (gathered irradiance, visibility) per point.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Points { vec4 points[]; };  // (x, 0), (n, 0) pairs
layout(std430, binding = 1) writeonly buffer Result { vec4 result[]; };
uniform int count;
uniform float lod_min;
#include "vct_trace.glsl"

void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i >= count) return;
    result[i] = vct_diffuse(points[2 * i].xyz, normalize(points[2 * i + 1].xyz), lod_min);
}
