#version 430
// Test probe (realtime/techniques/vct/vct.py VoxelScene.trace_cone): single cones as vct_cone traces them,
// each from an origin along a direction with a given tan(half-angle) and start distance, leaving the
// surface through a given point with a given normal: (radiance gathered, occlusion) per cone.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Cones { vec4 cones[]; };  // (origin, t0), (d, tan), (surface, 0), (n, 0)
layout(std430, binding = 1) writeonly buffer Result { vec4 result[]; };
uniform int count;
uniform float lod_min;
#include "vct_trace.glsl"

void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i >= count) return;
    vec4 o = cones[4 * i], d = cones[4 * i + 1];
    result[i] = vct_cone(o.xyz, normalize(d.xyz), d.w, o.w, lod_min, cones[4 * i + 2].xyz,
                         normalize(cones[4 * i + 3].xyz));
}
