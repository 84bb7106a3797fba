"""The storage structures of experiments/voxel_storage/ on hand cases: Morton codes by hand, the SVO's
node counts and bytes, the SVDAG of a grid of repeated blocks (node counts derived by hand), round trips
(every structure decodes to its input; a DAG merging by child mask alone does not), the cascades against
the triangles voxelised into each cascade's own grid, the dense grid's bytes by formula, and the verdict
on synthetic ratios (growing: holds; shrinking: does not)."""

from __future__ import annotations

import numpy as np
import pytest

from experiments.voxel_storage import cascaded, compare, dag, dense, morton, morton_octree, octree
from experiments.voxel_storage.voxelize import Grid, VoxelSet, cube_grid, ids_of, voxelize
from scenes.geometry import atrium


def voxel_set(coords, r: int) -> VoxelSet:
    ids = np.unique(ids_of(np.asarray(coords).reshape(-1, 3), r))
    return VoxelSet(r, ids)


def random_set(seed: int, r: int = 32, n: int = 2000) -> VoxelSet:
    return voxel_set(np.random.default_rng(seed).integers(0, r, (n, 3)), r)


# ---------------------------------------------------------------- Morton codes

@pytest.mark.parametrize("xyz, code", [((1, 0, 0), 4), ((0, 1, 0), 2), ((0, 0, 1), 1), ((2, 0, 0), 32),
                                       ((3, 3, 3), 63), ((5, 0, 6), 0b101_001_100)])
def test_morton_by_hand(xyz, code):
    # bit i of x at 3i + 2, of y at 3i + 1, of z at 3i: (5, 0, 6) = x 101, z 110: the (x y z) triples of
    # bits 2, 1, 0 are 101, 001, 100
    assert morton.encode(np.array([xyz]))[0] == code
    assert tuple(morton.decode(np.array([code]))[0]) == xyz


def test_morton_parent_is_the_code_shifted():
    c = np.random.default_rng(0).integers(0, 1 << 20, (500, 3))
    k = morton.encode(c)
    assert np.array_equal(morton.decode(k), c)
    assert np.array_equal(k >> 3, morton.encode(c >> 1))
    assert np.array_equal(k & 7, 4 * (c[:, 0] & 1) + 2 * (c[:, 1] & 1) + (c[:, 2] & 1))


# ---------------------------------------------------------------- SVO

def test_svo_single_voxel():
    t = octree.build(voxel_set([(5, 2, 7)], 8))
    assert t.nodes_per_level == (1, 1, 1, 1)
    fp = octree.footprint(t, 1.0)
    assert (fp.nodes, fp.bytes_geometry, fp.bytes) == (3, 3 * 5, 3 * 5 + 48)


def test_svo_opposite_corners_and_a_full_block():
    assert octree.build(voxel_set([(0, 0, 0), (7, 7, 7)], 8)).nodes_per_level == (1, 2, 2, 2)
    block = [(x, y, z) for x in range(2) for y in range(2) for z in range(2)]
    t = octree.build(voxel_set(block, 8))
    assert t.nodes_per_level == (1, 1, 1, 8)
    assert [int(m[0]) for m in t.masks] == [1, 1, 255]


@pytest.mark.parametrize("seed", range(3))
def test_svo_round_trip(seed):
    v = random_set(seed)
    t = octree.build(v)
    assert np.array_equal(octree.decode(t), morton.encode(v.coords()[np.argsort(morton.encode(v.coords()))]))
    # control: one mask bit moved decodes to another set
    bad = octree.Octree(t.resolution, t.masks[:-1] + [t.masks[-1] ^ np.uint8(1)], t.first_child, t.leaves)
    assert not np.array_equal(octree.decode(bad), t.leaves)


# ---------------------------------------------------------------- SVDAG

def tiled(r: int) -> VoxelSet:
    """An r^3 grid tiled by one 4^3 block: its octants (2^3 blocks) hold pattern A (voxel (0,0,0) only) where
    the octant's x is 0 and pattern B (the whole 2^3 block) where it is 1."""
    coords = []
    for x, y, z in np.ndindex(r, r, r):
        full = (x % 4) >= 2
        if full or (x % 2, y % 2, z % 2) == (0, 0, 0):
            coords.append((x, y, z))
    return voxel_set(coords, r)


def test_dag_of_repeated_blocks_by_hand():
    # 8^3 (L = 3). SVO: 1 root, 8 nodes of 4^3, 64 nodes of 2^3, leaves: per 4^3 block 4 x 1 + 4 x 8 = 36.
    # DAG: level 2 (2^3 nodes, their masks): A = 0b1 and B = 0xff: 2 nodes; level 1 (4^3 blocks): all the same
    # (A in the x = 0 octants, B in the x = 1 ones): 1 node; the root: 1 node.
    v = tiled(8)
    t = octree.build(v)
    assert t.nodes_per_level == (1, 8, 64, 8 * 36)
    d = dag.build(t)
    assert d.nodes_per_level == (1, 1, 2)
    # bytes: 4 nodes x 4-byte mask words + pointers: the root 8, the 4^3 node 8 (level-2 nodes: none)
    assert dag.footprint(d, 1.0).bytes_geometry == 4 * 4 + 16 * 4
    assert dag.footprint(d, 1.0).bytes == 4 * 4 + 16 * 4 + 4 * 4 + 8 * 36 * 48
    # 16^3: one more level of identical blocks
    assert dag.build(octree.build(tiled(16))).nodes_per_level == (1, 1, 1, 2)


@pytest.mark.parametrize("seed", range(3))
def test_dag_round_trip_and_mask_only_control(seed):
    v = random_set(seed)
    t = octree.build(v)
    d = dag.build(t)
    assert np.array_equal(dag.decode(d), t.leaves)
    assert sum(d.nodes_per_level) <= sum(t.nodes_per_level[:-1])
    # control: merging nodes by their child mask alone (ignoring which children) loses voxels
    wrong = dag.build(t, key=lambda table: table >= 0)
    assert not np.array_equal(dag.decode(wrong), t.leaves)


def test_dag_round_trip_on_the_atrium():
    m = atrium.atrium(2, 1)
    tris = compare.triangles_of(m.positions, m.indices)
    v = voxelize(tris, cube_grid(m.positions.min(0), m.positions.max(0), 64))
    t = octree.build(v)
    assert np.array_equal(octree.decode(t), t.leaves)
    assert np.array_equal(dag.decode(dag.build(t)), t.leaves)


# ---------------------------------------------------------------- Morton octree

def test_morton_octree_lookup():
    v = random_set(4, 16, 600)
    codes = morton_octree.build(v)
    members = {tuple(c) for c in v.coords()}
    queries = np.array(list(np.ndindex(16, 16, 16)))
    expected = np.array([tuple(q) in members for q in queries])
    assert np.array_equal(morton_octree.contains(codes, queries), expected)
    # control: unsorted codes break the binary search
    shuffled = np.random.default_rng(1).permutation(codes)
    assert not np.array_equal(morton_octree.contains(shuffled, queries), expected)
    fp = morton_octree.footprint(codes, 1.0)
    assert fp.bytes == v.count * 56 and fp.bytes_geometry == v.count * 8


# ---------------------------------------------------------------- dense and cascaded

def test_dense_bytes_by_formula():
    v = voxel_set([(1, 2, 3)], 512)
    fp = dense.footprint(v, 1.0)
    assert fp.bytes == 6_442_450_944 and fp.bytes_geometry == 134_217_728  # 512^3 x 48, 512^3 x 1
    grid = dense.build(voxel_set([(1, 2, 3)], 16))
    assert grid.sum() == 1 and grid[1, 2, 3] == 1


def test_dense_above_the_allocation_limit_is_not_built(monkeypatch):
    monkeypatch.setattr(dense, "DENSE_ALLOCATION_LIMIT", 1000)
    assert dense.build(voxel_set([(1, 2, 3)], 16)) is None


def test_cascade_layout_and_coverage_by_hand():
    # R = 16, 3 cascades of r = 4: cascade 0 covers voxels 6..9 of the fine grid, cascade 1 3..6 of the 8^3
    assert cascaded.box_of(16, 3, 0) == (6, 10) and cascaded.box_of(16, 3, 1) == (2, 6)
    assert cascaded.box_of(16, 3, 2) == (0, 4)
    v = voxel_set([(7, 7, 7), (8, 9, 6), (9, 9, 9), (0, 0, 0)], 16)
    grids = cascaded.build(v, 3)
    fp = cascaded.footprint(grids, v, 1.0)
    assert fp.cells == 3 * 4 ** 3 and fp.bytes == 3 * 64 * 48
    assert fp.covered == pytest.approx(3 / 4)
    # cascade 0: the three central voxels; cascade 1 (8^3, box 2..5): (3,3,3), (4,4,3), (4,4,4); (0,0,0) -> outside;
    # cascade 2 (4^3, all): (1,1,1), (2,2,1), (2,2,2), (0,0,0)
    assert fp.nodes_per_level == (3, 3, 4)
    lay = cascaded.layout(Grid((0.0, 0.0, 0.0), 0.5, 16), 3)
    assert lay.resolution == 4 and lay.voxel_size == pytest.approx(0.5) and lay.half_extent_of(2) == pytest.approx(4.0)


@pytest.mark.parametrize("count", [2, 3])
def test_cascades_equal_the_triangles_voxelised_into_each_cascade(count):
    # triangles spread over the whole grid (the atrium's centre is open air: its finest cascade is empty)
    rng = np.random.default_rng(3)
    tris = rng.uniform(0, 64, (300, 1, 3)) + rng.normal(0, 3, (300, 3, 3))
    grid = Grid((0.0, 0.0, 0.0), 1.0, 64)
    v = voxelize(tris, grid)
    direct = cascaded.voxelize_direct(tris, grid, count)
    for k in range(count):
        derived = cascaded.cascade_voxels(v, count, k)
        assert len(derived) > 0
        assert {tuple(c) for c in derived} == {tuple(c) for c in direct[k].coords()}
    # control: boxes anchored at the grid's corner instead of its centre give another set
    c = v.coords()
    wrong = {tuple(x) for x in np.unique(c[(c < 64 >> (count - 1)).all(axis=1)], axis=0)}
    assert wrong != {tuple(x) for x in direct[0].coords()}


def test_layout_refuses_too_many_cascades():
    with pytest.raises(ValueError, match="cascades = 5"):
        cascaded.layout(Grid((0.0, 0.0, 0.0), 1.0, 16), 5)


# ---------------------------------------------------------------- the verdict

def synthetic_rows(svo_bytes) -> list[compare.Row]:
    """Two scenes x two resolutions; the cascades 100 bytes, dense 2000, the sparse ones from svo_bytes."""
    rows = []
    for scene, tris in (("small", 10), ("large", 1000)):
        for res in (32, 64):
            for s in compare.STRUCTURES:
                b = {"cascaded": 100, "dense": 2000}.get(s, svo_bytes[(scene, res)])
                rows.append(compare.Row(scene, tris, res, s, 1, 1, 0, b, b, 0.0, 1.0, 1.0, ()))
    return rows


def test_verdict_from_the_ratios():
    growing = synthetic_rows({("small", 32): 100, ("small", 64): 300, ("large", 32): 200, ("large", 64): 900})
    v = compare.verdict(growing)
    svo = next(t for t in v.trends if t.structure == "svo")
    assert svo.by_resolution == (2.0, 9.0) and svo.by_size == (3.0, 9.0)
    assert v.holds_for(svo) is True
    assert v.holds is False  # the dense ratio is constant (20, 20): it does not grow
    # control: shrinking ratios are not called growing
    shrinking = compare.verdict(synthetic_rows({("small", 32): 900, ("small", 64): 300, ("large", 32): 800,
                                                ("large", 64): 200}))
    assert shrinking.holds_for(next(t for t in shrinking.trends if t.structure == "svo")) is False
    assert "does not hold" in shrinking.sentences()[-2]
