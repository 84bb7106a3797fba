#version 430
// One mip step of the paper's filter on a 2D parameterization: each texel of level L+1 is the mean
// of a 2x2 block of L, per layer (downsample.comp for texture arrays).
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 0) uniform readonly image2DArray src;
layout(rgba32f, binding = 1) uniform writeonly image2DArray dst;
uniform int dst_size;

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (g.x >= dst_size || g.y >= dst_size) return;
    ivec3 s = ivec3(2 * g.xy, g.z);
    vec4 sum = imageLoad(src, s) + imageLoad(src, s + ivec3(1, 0, 0))
             + imageLoad(src, s + ivec3(0, 1, 0)) + imageLoad(src, s + ivec3(1, 1, 0));
    imageStore(dst, g, 0.25 * sum);
}
