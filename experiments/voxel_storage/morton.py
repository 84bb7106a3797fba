"""Morton (Z-order) codes of voxel coordinates: the bits of x, y and z interleaved.

code = sum_i x_i 2^(3i+2) + y_i 2^(3i+1) + z_i 2^(3i) for the bits x_i, y_i, z_i of the coordinates
(Morton 1966; the order Baert, Lagae & Dutre 2013 sort voxels by). So `code >> 3` is the code of the
parent voxel (coordinates halved) and `code & 7` = 4 x_0 + 2 y_0 + z_0 is the child's octant: sorting the
codes sorts every octree level at once, each node's children consecutive. Up to 21 bits per axis
(resolution 2^21), int64.
"""

from __future__ import annotations

import numpy as np

#: bits per axis that fit in an int64 code
MAX_BITS = 21


def _spread(v: np.ndarray) -> np.ndarray:
    """Bit i of v moved to bit 3i (v < 2^21): the standard shift-and-mask sequence ("part1by2")."""
    x = v.astype(np.uint64) & np.uint64(0x1FFFFF)
    x = (x | (x << np.uint64(32))) & np.uint64(0x1F00000000FFFF)
    x = (x | (x << np.uint64(16))) & np.uint64(0x1F0000FF0000FF)
    x = (x | (x << np.uint64(8))) & np.uint64(0x100F00F00F00F00F)
    x = (x | (x << np.uint64(4))) & np.uint64(0x10C30C30C30C30C3)
    x = (x | (x << np.uint64(2))) & np.uint64(0x1249249249249249)
    return x


def _compact(x: np.ndarray) -> np.ndarray:
    """The inverse of _spread: bit 3i of x moved to bit i."""
    x = x.astype(np.uint64) & np.uint64(0x1249249249249249)
    x = (x | (x >> np.uint64(2))) & np.uint64(0x10C30C30C30C30C3)
    x = (x | (x >> np.uint64(4))) & np.uint64(0x100F00F00F00F00F)
    x = (x | (x >> np.uint64(8))) & np.uint64(0x1F0000FF0000FF)
    x = (x | (x >> np.uint64(16))) & np.uint64(0x1F00000000FFFF)
    x = (x | (x >> np.uint64(32))) & np.uint64(0x1FFFFF)
    return x


def encode(coords: np.ndarray) -> np.ndarray:
    """(N, 3) non-negative integer coordinates -> (N,) int64 Morton codes."""
    c = np.asarray(coords)
    code = (_spread(c[:, 0]) << np.uint64(2)) | (_spread(c[:, 1]) << np.uint64(1)) | _spread(c[:, 2])
    return code.astype(np.int64)


def decode(codes: np.ndarray) -> np.ndarray:
    """(N,) Morton codes -> (N, 3) int64 coordinates."""
    c = np.asarray(codes).astype(np.uint64)
    return np.stack([_compact(c >> np.uint64(2)), _compact(c >> np.uint64(1)), _compact(c)], 1).astype(np.int64)
