#version 430
// Read-back of one mip level of one voxel texture, RGBA16F or, with DUMP_RGBA8, RGBA8
// (realtime/techniques/vct/vct.py VoxelScene.read_faces, read_normals, read_columns: tests).
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
#ifdef DUMP_RGBA8
layout(rgba8, binding = 0) uniform readonly image3D src;
#else
layout(rgba16f, binding = 0) uniform readonly image3D src;
#endif
layout(std430, binding = 1) writeonly buffer Out { vec4 texels[]; };
uniform ivec3 size;

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(g, size))) return;
    texels[(g.z * size.y + g.y) * size.x + g.x] = imageLoad(src, g);
}
