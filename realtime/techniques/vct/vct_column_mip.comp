#version 430
// One level of the column texture's mip (realtime/techniques/vct/vct.py): channel a of a level-0 voxel is
// its surface's coverage along axis a (vct_inject.comp), and of a texel the largest coverage along a of
// the columns of level-0 voxels it holds: the 2x2x2 children pair up along axis a, composited as
// opacities 1 - (1 - a_front)(1 - a_back) (an opacity alone needs no face per direction: the composite is
// symmetric), and the texel keeps the largest of its four pairs (not their mean). A cone's axis crosses
// one column of the texel, not known which (the lookup is nearest): the largest is what it may cross.
// Cascades are stacked along z, each R_L deep at level L: children never cross a cascade.
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(rgba16f, binding = 0) uniform readonly image3D src;
layout(rgba16f, binding = 1) uniform writeonly image3D dst;
uniform ivec3 dst_size;

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(g, dst_size))) return;
    ivec3 s = 2 * g;
    vec4 out_ = vec4(0.0);
    for (int axis = 0; axis < 3; ++axis) {
        ivec3 e = ivec3(0), u = ivec3(0), w = ivec3(0);
        e[axis] = 1;
        u[(axis + 1) % 3] = 1;
        w[(axis + 2) % 3] = 1;
        float top = 0.0;
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j) {
                ivec3 p = s + i * u + j * w;
                float a = imageLoad(src, p)[axis], b = imageLoad(src, p + e)[axis];
                top = max(top, 1.0 - (1.0 - a) * (1.0 - b));
            }
        out_[axis] = top;
    }
    imageStore(dst, g, out_);
}
