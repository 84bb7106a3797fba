#version 430
// Copy one level of a 2D parameterization (texture array) into a buffer (tests, previews).
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 0) uniform readonly image2DArray src;
layout(std430, binding = 3) writeonly buffer Out { vec4 texel[]; };
uniform int size;
void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (g.x >= size || g.y >= size) return;
    texel[(g.z * size + g.y) * size + g.x] = imageLoad(src, g);
}
