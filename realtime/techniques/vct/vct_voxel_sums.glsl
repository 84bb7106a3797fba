// The voxeliser's integer sums of one cascade (vct_voxelize.comp writes them, vct_normals.comp and
// vct_inject.comp read them): VOXEL_INTS ints a voxel, voxel v = (z R + y) R + x, held in two storage
// buffers, voxels [0, vct_sums_split) in the first and the rest in the second (realtime/techniques/vct/vct.py).
// One buffer would hold R^3 VOXEL_INTS 4 bytes: 2.28 GB at 256^3, and Mesa llvmpipe crashed the process
// reading past byte 2^31 of a buffer (an atomic add there worked); halved, 256^3 needs 1.14 GB a buffer.
// VCT_SUMS_ATOMIC (the voxeliser): the buffers are written with atomics; otherwise they are read only.
#ifdef VCT_SUMS_ATOMIC
layout(std430, binding = 1) coherent buffer VoxelSumsLow { int sums_low[]; };
layout(std430, binding = 3) coherent buffer VoxelSumsHigh { int sums_high[]; };
#else
layout(std430, binding = 1) readonly buffer VoxelSumsLow { int sums_low[]; };
layout(std430, binding = 3) readonly buffer VoxelSumsHigh { int sums_high[]; };
#endif
uniform int vct_sums_split;  // the voxels the first buffer holds

// int k of voxel v's sums
int voxel_sum(int v, int k) {
    return v < vct_sums_split ? sums_low[v * VOXEL_INTS + k] : sums_high[(v - vct_sums_split) * VOXEL_INTS + k];
}

#ifdef VCT_SUMS_ATOMIC
// adds `value` to int k of voxel v's sums
void voxel_sum_add(int v, int k, int value) {
    if (v < vct_sums_split) atomicAdd(sums_low[v * VOXEL_INTS + k], value);
    else atomicAdd(sums_high[(v - vct_sums_split) * VOXEL_INTS + k], value);
}
#endif
