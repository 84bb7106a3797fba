#version 430
// Level 0 of the solid-angle-weighted chain (gpu.py's EnvironmentFilter.solid_angle_chain): each texel's
// radiance times its solid angle, and that solid angle in alpha.
// The 2x2 box chain (downsample.comp) then carries sums of radiance times solid angle and of solid angle, so a
// read's rgb / a is the mean radiance over the texels it blends, each weighted by the solid angle it covers.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 0) uniform readonly imageCube src;
layout(rgba32f, binding = 1) uniform writeonly imageCube dst;
uniform sampler2D solid_angle;  // (size, size): each texel's solid angle (all faces alike)
uniform int size;

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (g.x >= size || g.y >= size) return;
    float w = texelFetch(solid_angle, g.xy, 0).r;
    imageStore(dst, g, vec4(imageLoad(src, g).rgb * w, w));
}
