"""The Morton-ordered sparse octree of Baert, Lagae & Dutre, "Out-of-core construction of sparse voxel
octrees" (HPG 2013): the set voxels as a list sorted by Morton code (experiments/voxel_storage/morton.py),
each with its payload; the inner nodes are implicit (a node is a run of codes sharing a prefix, found by
binary search), so nothing but the codes is stored.

Bytes = N x (8 + 48): a 64-bit code per voxel (as Baert et al.'s builder; 3 log2 R bits would do) and the
48-byte payload; geometry only: N x 8. Building: encode and sort the codes.
"""

from __future__ import annotations

import numpy as np

from experiments.voxel_storage import morton
from experiments.voxel_storage.footprint import PAYLOAD_BYTES, Footprint
from experiments.voxel_storage.voxelize import VoxelSet

#: bytes of one stored Morton code
CODE_BYTES = 8


def build(voxels: VoxelSet) -> np.ndarray:
    """The voxels' Morton codes, sorted (int64)."""
    codes = morton.encode(voxels.coords())
    codes.sort()
    return codes


def contains(codes: np.ndarray, coords: np.ndarray) -> np.ndarray:
    """Whether each (x, y, z) is a set voxel: a binary search for its code."""
    key = morton.encode(np.asarray(coords))
    at = np.minimum(np.searchsorted(codes, key), max(len(codes) - 1, 0))
    return (codes[at] == key) if len(codes) else np.zeros(len(key), dtype=bool)


def footprint(codes: np.ndarray, voxel_size: float) -> Footprint:
    n = len(codes)
    return Footprint("morton", n, n, 0, n * (CODE_BYTES + PAYLOAD_BYTES), n * CODE_BYTES, voxel_size, 1.0)
