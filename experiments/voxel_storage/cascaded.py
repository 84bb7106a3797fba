"""The cascaded texture of iblcheck's VCT (realtime/techniques/vct/vct_math.py, `Cascades`): c nested
cubic grids of r^3 voxels, centred on the scene, each twice the extent of the one inside it.

Compared at equal FINEST voxel size: the other structures store the whole scene's grid of R^3 voxels of
edge h = L / R (L the scene's cube); the cascades store c grids of r = R / 2^(c-1) voxels, the outermost
(cascade c - 1, voxel h 2^(c-1)) covering the same cube L, the finest (cascade 0, voxel h) only the central
cube of edge L / 2^(c-1). So they hold c r^3 = c R^3 / 8^(c-1) voxels (bytes x 48), a fixed fraction
c / 8^(c-1) of the dense grid's at every resolution, but the scene's surface at voxel h only inside
the finest cascade: `covered` is the fraction of the finest-voxel set lying there (the rest is stored at
2, 4, ... times coarser voxels). That is what the cascades buy their memory with: for a camera inside the
scene, detail where it looks from; for "storing a large scene", a coarse outer.

Cascade k's voxels are exactly the parents (coordinates >> k) of the fine voxels inside its box: a coarse
closed box is the union of its 2^(3k) fine boxes, so a triangle overlaps it iff it overlaps one of them (the
conservative voxelisation at R / 2^k restricted to the box gives the same set; the test checks this).
Building is the scatter of those parents into c dense r^3 occupancy grids. `voxelize_direct` is the
seed's own pipeline instead: the triangles voxelised into each cascade's grid (c voxelisations of r^3);
its time is the cascades' voxelisation time (the "voxelize-cascades" row of compare.py).
"""

from __future__ import annotations

import numpy as np

from experiments.voxel_storage.footprint import OCCUPANCY_BYTES, PAYLOAD_BYTES, Footprint
from experiments.voxel_storage.voxelize import Grid, VoxelSet, voxelize
from realtime.techniques.vct.vct_math import Cascades


def layout(grid: Grid, count: int) -> Cascades:
    """The cascades over `grid` at equal finest voxel: r = R / 2^(count - 1), the outermost the whole cube."""
    r = grid.resolution >> (count - 1)
    if count < 1 or r < 2 or r << (count - 1) != grid.resolution:
        raise ValueError(f"cascades = {count}: resolution {grid.resolution} must be a multiple of "
                         f"2^{count} (each cascade at least 2 voxels wide)")
    centre = tuple(o + grid.extent / 2.0 for o in grid.origin)
    return Cascades(centre, grid.extent / 2.0 / 2 ** (count - 1), r, count)


def box_of(resolution: int, count: int, k: int) -> tuple[int, int]:
    """[first, last) voxel index along each axis of cascade k in the grid of resolution R / 2^k."""
    r = resolution >> (count - 1)
    rk = resolution >> k
    return (rk - r) // 2, (rk + r) // 2


def cascade_grid(grid: Grid, count: int, k: int) -> Grid:
    """Cascade k's own r^3 grid: voxel h 2^k, its corner `first` coarse voxels into the whole cube."""
    first, last = box_of(grid.resolution, count, k)
    h = grid.voxel * 2 ** k
    return Grid(tuple(o + first * h for o in grid.origin), h, last - first)


def voxelize_direct(triangles: np.ndarray, grid: Grid, count: int) -> list[VoxelSet]:
    """Each cascade's voxels, the triangles voxelised into its own grid (cascade 0 the finest)."""
    return [voxelize(triangles, cascade_grid(grid, count, k)) for k in range(count)]


def cascade_voxels(voxels: VoxelSet, count: int, k: int) -> np.ndarray:
    """(N_k, 3) coordinates of cascade k's set voxels, relative to its box's corner (unique)."""
    first, last = box_of(voxels.resolution, count, k)
    c = voxels.coords() >> k
    c = c[((c >= first) & (c < last)).all(axis=1)] - first
    r = last - first
    ids = np.unique((c[:, 0] * r + c[:, 1]) * r + c[:, 2])
    return np.stack([ids // (r * r), (ids // r) % r, ids % r], 1)


def build(voxels: VoxelSet, count: int) -> np.ndarray:
    """(count, r, r, r) uint8 occupancy of the cascades (cascade 0 the finest)."""
    r = voxels.resolution >> (count - 1)
    grids = np.zeros((count, r, r, r), dtype=np.uint8)
    for k in range(count):
        c = cascade_voxels(voxels, count, k)
        grids[k, c[:, 0], c[:, 1], c[:, 2]] = 1
    return grids


def footprint(grids: np.ndarray, voxels: VoxelSet, voxel_size: float) -> Footprint:
    count, r = grids.shape[0], grids.shape[1]
    cells = count * r ** 3
    first, last = box_of(voxels.resolution, count, 0)
    c = voxels.coords()
    inside = int(((c >= first) & (c < last)).all(axis=1).sum())
    return Footprint("cascaded", cells, int(grids.sum(dtype=np.int64)), 0, cells * PAYLOAD_BYTES,
                     cells * OCCUPANCY_BYTES, voxel_size, inside / max(voxels.count, 1),
                     tuple(int(g.sum(dtype=np.int64)) for g in grids))
