#version 430
// Irradiance map, pass 1 (realtime/techniques/irradiance_map/irradiance_convolution.py): pack the source level for the convolution.
// Each source texel t becomes two vec4s, (w dOmega, dOmega) and (L, 1), in a buffer that pass 2
// streams through (on llvmpipe, buffer reads at a loop-uniform index are cheap; image loads and
// shared-memory tiles with their barriers cost 3x more).
layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;
layout(rgba32f, binding = 0) uniform readonly imageCube source;
uniform sampler2D weights;  // (source_size, 6 source_size): xyz = w dOmega, w = dOmega (float64 on the host)
uniform int source_size;
layout(std430, binding = 4) writeonly buffer Packed { vec4 packed_texels[]; };  // 2 per texel

void main() {
    int t = int(gl_GlobalInvocationID.x);
    int per_face = source_size * source_size;
    if (t >= 6 * per_face) return;
    int f = t / per_face;
    int r = t - f * per_face;
    int y = r / source_size;
    int x = r - y * source_size;
    packed_texels[2 * t] = texelFetch(weights, ivec2(x, y + f * source_size), 0);
    packed_texels[2 * t + 1] = vec4(imageLoad(source, ivec3(x, y, f)).rgb, 1.0);
}
