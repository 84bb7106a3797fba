"""The sparse voxel octree (SVO) with child pointers, in the compact layout of Laine & Karras, "Efficient
sparse voxel octrees" (I3D 2010): a node's children stored consecutively, the node holding an 8-bit child
mask and one pointer to its first child.

Levels 0 (the root, one node) .. L = log2(R) (the set voxels, the leaves). A node at level l is the cube of
the grid of resolution 2^l containing its voxels; its Morton code is its leaves' codes >> 3 (L - l)
(experiments/voxel_storage/morton.py), so building is: sort the voxels' codes once, then per level
from the leaves up, the parents' codes are the runs of equal code >> 3 (their first index is the first
child's pointer; the OR of 1 << (code & 7) over the run is the mask). Every level comes out in Morton
order, the children of a node consecutive.

Bytes: every inner node 1 (mask) + 4 (first-child pointer) = INNER_NODE_BYTES = 5, every leaf its
48-byte payload (geometry only: the leaves cost nothing beyond their parent's mask bit). Laine & Karras pack
mask and pointer into one 32-bit descriptor with a far-pointer escape; 5 bytes is the simple pointer octree.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from experiments.voxel_storage import morton
from experiments.voxel_storage.footprint import PAYLOAD_BYTES, Footprint
from experiments.voxel_storage.voxelize import VoxelSet

#: an inner node: 8-bit child mask + 32-bit pointer to its first child
INNER_NODE_BYTES = 1 + 4


@dataclass(frozen=True)
class Octree:
    resolution: int
    masks: list[np.ndarray]  # per inner level 0 .. L-1: (n_l,) uint8 child masks, Morton order
    first_child: list[np.ndarray]  # per inner level: (n_l,) index of the first child in level l + 1
    leaves: np.ndarray  # (N,) Morton codes of the set voxels, sorted

    @property
    def nodes_per_level(self) -> tuple[int, ...]:
        return tuple(len(m) for m in self.masks) + (len(self.leaves),)


def depth_of(resolution: int) -> int:
    depth = int(resolution).bit_length() - 1
    if resolution < 1 or 1 << depth != resolution or depth > morton.MAX_BITS:
        raise ValueError(f"resolution {resolution}: an octree needs a power of two up to 2^{morton.MAX_BITS}")
    return depth


def runs(codes: np.ndarray) -> np.ndarray:
    """First index of every run of equal values in a sorted array."""
    return np.flatnonzero(np.r_[True, codes[1:] != codes[:-1]]) if len(codes) else np.zeros(0, dtype=np.int64)


def parent_level(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(parent codes, their child masks, first-child indices) of a sorted level of node codes."""
    parents = codes >> 3
    first = runs(parents)
    bits = (np.int64(1) << (codes & 7)).astype(np.uint8)
    masks = np.bitwise_or.reduceat(bits, first) if len(first) else np.zeros(0, dtype=np.uint8)
    return parents[first], masks.astype(np.uint8), first


def sorted_codes(voxels: VoxelSet) -> np.ndarray:
    """The voxels' Morton codes, sorted."""
    codes = morton.encode(voxels.coords())
    codes.sort()
    return codes


def build(voxels: VoxelSet, codes: np.ndarray | None = None) -> Octree:
    """The pointer SVO of the voxel set (its sorted Morton codes may be passed in)."""
    depth = depth_of(voxels.resolution)
    leaves = sorted_codes(voxels) if codes is None else codes
    masks, first_child = [], []
    level = leaves
    for _ in range(depth):
        level, m, first = parent_level(level)
        masks.append(m)
        first_child.append(first.astype(np.uint32))
    return Octree(voxels.resolution, masks[::-1], first_child[::-1], leaves)


def decode(tree: Octree) -> np.ndarray:
    """The sorted Morton codes of the leaves, found by walking the masks from the root (the round trip)."""
    codes = np.zeros(1 if len(tree.masks) and len(tree.masks[0]) else 0, dtype=np.int64)
    for masks in tree.masks:
        codes = _children(codes, masks)
    return codes


def _children(codes: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """Codes of the children each node's mask names, in Morton order."""
    bits = np.unpackbits(masks[:, None], axis=1, bitorder="little").astype(bool)  # (n, 8): bit o = octant o
    node, octant = np.nonzero(bits)
    return codes[node] * 8 + octant


def footprint(tree: Octree, voxel_size: float) -> Footprint:
    inner = sum(len(m) for m in tree.masks)
    leaves = len(tree.leaves)
    geometry = inner * INNER_NODE_BYTES
    return Footprint("svo", leaves, leaves, inner, geometry + leaves * PAYLOAD_BYTES, geometry, voxel_size, 1.0,
                     tree.nodes_per_level)
