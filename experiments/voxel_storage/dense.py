"""The dense 3D texture: every voxel of the resolution^3 grid stored, set or not.

Bytes = r^3 x 48 (the six-face RGBA16F texel, footprint.PAYLOAD_BYTES) and r^3 x 1 for an occupancy
grid. Building it is a scatter of the voxel set into a zeroed r^3 byte array (the occupancy; the payload
grid is only counted, never allocated: at 512^3 it would take 6.4 GB). Above DENSE_ALLOCATION_LIMIT the
occupancy grid is not allocated either and `build` returns None.
"""

from __future__ import annotations

import numpy as np

from experiments.voxel_storage.footprint import OCCUPANCY_BYTES, PAYLOAD_BYTES, Footprint
from experiments.voxel_storage.voxelize import VoxelSet

#: the largest occupancy grid `build` allocates (bytes): 512^3 fits, 1024^3 does not
DENSE_ALLOCATION_LIMIT = 1 << 28


def build(voxels: VoxelSet) -> np.ndarray | None:
    """The r^3 occupancy grid (uint8, x-major) of the voxel set; None above DENSE_ALLOCATION_LIMIT."""
    r = voxels.resolution
    if r ** 3 * OCCUPANCY_BYTES > DENSE_ALLOCATION_LIMIT:
        return None
    grid = np.zeros(r ** 3, dtype=np.uint8)
    grid[voxels.ids] = 1
    return grid.reshape(r, r, r)


def footprint(voxels: VoxelSet, voxel_size: float) -> Footprint:
    cells = voxels.resolution ** 3
    return Footprint("dense", cells, voxels.count, 0, cells * PAYLOAD_BYTES, cells * OCCUPANCY_BYTES, voxel_size,
                     1.0)
