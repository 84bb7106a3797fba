"""The sparse voxel DAG (SVDAG) of Kaempe, Sintorn & Assarsson, "High resolution sparse voxel DAGs"
(SIGGRAPH 2013): the SVO with identical subtrees stored once.

Built bottom-up from the SVO's levels (experiments/voxel_storage/octree.py): at level L - 1 (the nodes
whose children are voxels) a node is its 8-bit mask, and nodes of equal masks are one node; at every
level above, a node is the 8-tuple of its children's DAG ids (-1 where a child is empty; the mask is
implied), and nodes of equal tuples are one node (np.unique over the rows: an exact hash of mask and
children). Two subtrees are merged iff they hold the same voxels at the same relative positions, so the
DAG decodes to the input set (`decode`, the round trip; merging by the mask alone would not).

Bytes, as Kaempe et al.: a node is a 32-bit mask word plus a 32-bit pointer per child present; the nodes
at level L - 1 are their mask word alone (their children are voxels, bits of the mask).
The payload is not shareable: two identical subtrees hold the same voxels but not the same colours, so
a DAG with attributes keeps them apart, in voxel (Morton) order, and indexes them by counting the voxels
left of a path (Dado et al., "Geometry and attribute compression for voxel scenes", Eurographics 2016):
bytes with payload = geometry + 4 bytes per node (its subtree's voxel count) + N x 48.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from experiments.voxel_storage.footprint import PAYLOAD_BYTES, Footprint
from experiments.voxel_storage.octree import Octree, runs

#: a node's 32-bit mask word, a 32-bit pointer per child, a 32-bit voxel count when it carries a payload
MASK_BYTES, POINTER_BYTES, COUNT_BYTES = 4, 4, 4


@dataclass(frozen=True)
class Dag:
    resolution: int
    children: list[np.ndarray]  # per level 0 .. L-2: (n_l, 8) int64 ids into level l + 1's nodes (-1: empty)
    leaf_masks: np.ndarray  # level L - 1: (n, ) uint8 masks of voxels
    voxels: int  # set voxels it stands for

    @property
    def nodes_per_level(self) -> tuple[int, ...]:
        return tuple(len(c) for c in self.children) + (len(self.leaf_masks),)


def build(tree: Octree, key=None) -> Dag:
    """Merge the SVO's identical subtrees. `key(table)` maps a level's (n, 8) child-id table to the rows
    unique nodes are found by (default: the table itself)."""
    depth = len(tree.masks)
    if depth == 0:
        return Dag(tree.resolution, [], np.zeros(0, dtype=np.uint8), len(tree.leaves))
    # level L - 1: nodes are their masks
    leaf_masks, ids = np.unique(tree.masks[-1], return_inverse=True)
    children: list[np.ndarray] = []
    # the SVO's node codes per level, to find each node's parent and octant
    parents = tree.leaves >> 3
    codes = [parents[runs(parents)]]
    for _ in range(depth - 1):
        c = codes[-1]
        codes.append(c[runs(c >> 3)] >> 3)
    # codes[i] = the codes of SVO level L - 1 - i (unique, sorted)
    for i in range(1, depth):
        child_codes = codes[i - 1]
        parent_of = np.cumsum(np.r_[True, (child_codes[1:] >> 3) != (child_codes[:-1] >> 3)]) - 1
        table = np.full((len(codes[i]), 8), -1, dtype=np.int64)
        table[parent_of, child_codes & 7] = ids.reshape(-1)
        rows = table if key is None else key(table)
        _, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
        children.append(table[first])
        ids = inverse.reshape(-1)
    return Dag(tree.resolution, children[::-1], leaf_masks.astype(np.uint8), len(tree.leaves))


def decode(dag: Dag) -> np.ndarray:
    """Sorted Morton codes of the voxels the DAG stands for, walking it from the root."""
    if not len(dag.leaf_masks):
        return np.zeros(0, dtype=np.int64)
    codes, nodes = np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64)
    for table in dag.children:
        rows = table[nodes]
        node, octant = np.nonzero(rows >= 0)
        codes, nodes = codes[node] * 8 + octant, rows[node, octant]
    bits = np.unpackbits(dag.leaf_masks[nodes][:, None], axis=1, bitorder="little").astype(bool)
    node, octant = np.nonzero(bits)
    return np.sort(codes[node] * 8 + octant)


def footprint(dag: Dag, voxel_size: float) -> Footprint:
    inner = sum(len(t) for t in dag.children)
    pointers = sum(int((t >= 0).sum()) for t in dag.children)
    nodes = inner + len(dag.leaf_masks)
    geometry = nodes * MASK_BYTES + pointers * POINTER_BYTES
    with_payload = geometry + nodes * COUNT_BYTES + dag.voxels * PAYLOAD_BYTES
    return Footprint("svdag", dag.voxels, dag.voxels, nodes, with_payload, geometry, voxel_size, 1.0,
                     dag.nodes_per_level)
