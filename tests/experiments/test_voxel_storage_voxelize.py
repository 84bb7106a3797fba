"""The conservative voxeliser (experiments/voxel_storage/voxelize.py) against a brute-force SAT written
here (every voxel of a small grid tested, 13 axes, scalar), against point samples of the triangles
(every voxel holding a sample must be set), and against analytic cases: an axis-aligned quad covers an
exact slab of voxels, a triangle inside one voxel sets one, a triangle on a grid plane sets both layers.
Control: a centre-sampling voxeliser (not conservative) misses the quad's edge voxels."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from experiments.voxel_storage import compare
from experiments.voxel_storage.voxelize import Grid, VoxelBudgetError, cube_grid, ids_of, voxelize
from scenes.geometry import meshes

UNIT = (0.0, 0.0, 0.0)


def brute_force(tri: np.ndarray, r: int) -> set[tuple[int, int, int]]:
    """Akenine-Moeller's 13-axis test of one triangle against every voxel [i, i+1]^3 of an r^3 grid."""
    e = np.eye(3)
    f = [tri[1] - tri[0], tri[2] - tri[1], tri[0] - tri[2]]
    axes = list(e) + [np.cross(f[0], f[1])] + [np.cross(a, b) for a in e for b in f]
    out = set()
    for ijk in itertools.product(range(r), repeat=3):
        v = tri - (np.array(ijk) + 0.5)
        separated = False
        for a in axes:
            p = v @ a
            rad = 0.5 * np.abs(a).sum()
            if p.min() > rad or p.max() < -rad:
                separated = True
                break
        if not separated:
            out.add(ijk)
    return out


def as_set(vs) -> set[tuple[int, int, int]]:
    return {tuple(int(x) for x in c) for c in vs.coords()}


def random_triangles(seed: int, r: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    tris = [rng.uniform(-1, r + 1, (3, 3)),  # large, partly outside
            rng.uniform(0, r, 3) + rng.normal(0, 0.4, (3, 3)),  # about a voxel
            rng.uniform(0, r, 3) + np.outer([0, 1, 1.0001], rng.normal(0, 2, 3))]  # a sliver
    return tris


@pytest.mark.parametrize("seed", range(6))
def test_matches_brute_force_sat(seed):
    r = 7
    for tri in random_triangles(seed, r):
        got = as_set(voxelize(tri[None], Grid(UNIT, 1.0, r)))
        assert got == brute_force(tri, r)


@pytest.mark.parametrize("seed", range(4))
def test_every_point_sample_lies_in_a_set_voxel(seed):
    # a second, SAT-free check of conservativeness: dense barycentric samples of the triangles
    rng = np.random.default_rng(100 + seed)
    r = 16
    tris = rng.uniform(0, r, (20, 3, 3))
    got = as_set(voxelize(tris, Grid(UNIT, 1.0, r)))
    u, v = np.meshgrid(np.linspace(0, 1, 60), np.linspace(0, 1, 60))
    keep = (u + v) <= 1
    u, v = u[keep], v[keep]
    pts = tris[:, 0, None] + u[None, :, None] * (tris[:, 1] - tris[:, 0])[:, None] + \
        v[None, :, None] * (tris[:, 2] - tris[:, 0])[:, None]
    cells = {tuple(c) for c in np.clip(np.floor(pts.reshape(-1, 3)), 0, r - 1).astype(int)}
    assert cells <= got


def quad(x0, x1, y0, y1, z) -> np.ndarray:
    a, b, c, d = (x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)
    return np.array([[a, b, c], [a, c, d]], dtype=np.float64)


def cross2(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def centre_sampled(tris: np.ndarray, r: int) -> set[tuple[int, int, int]]:
    """A NON-conservative voxeliser (the control): a voxel is set when its centre, projected along the
    triangle's dominant normal axis, falls inside the triangle and the plane is within half a voxel."""
    out = set()
    for tri in tris:
        n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
        k = int(np.argmax(np.abs(n)))
        i, j = [a for a in range(3) if a != k]
        for ijk in itertools.product(range(r), repeat=3):
            c = np.array(ijk) + 0.5
            depth = tri[0][k] - (n[i] * (c[i] - tri[0][i]) + n[j] * (c[j] - tri[0][j])) / n[k]
            if abs(depth - c[k]) > 0.5:
                continue
            p, a, b, cc = c[[i, j]], tri[0][[i, j]], tri[1][[i, j]], tri[2][[i, j]]
            s = [cross2(b - a, p - a), cross2(cc - b, p - b), cross2(a - cc, p - cc)]
            if all(x >= 0 for x in s) or all(x <= 0 for x in s):
                out.add(ijk)
    return out


def test_axis_aligned_quad_covers_its_slab_and_centre_sampling_does_not():
    # x in [0.3, 5.3], y in [1.2, 4.7], z = 2.25: voxels x 0..5, y 1..4, z 2 (closed boxes)
    tris = quad(0.3, 5.3, 1.2, 4.7, 2.25)
    expected = {(x, y, 2) for x in range(6) for y in range(1, 5)}
    assert as_set(voxelize(tris, Grid(UNIT, 1.0, 8))) == expected
    control = centre_sampled(tris, 8)
    assert control != expected and control < expected  # it misses the x = 5 column (centre 5.5 > 5.3)
    assert (5, 2, 2) in expected - control


def test_quad_on_a_grid_plane_sets_both_layers():
    tris = quad(0.5, 3.5, 0.5, 3.5, 2.0)
    assert as_set(voxelize(tris, Grid(UNIT, 1.0, 6))) == {(x, y, z) for x in range(4) for y in range(4)
                                                          for z in (1, 2)}


def test_triangle_inside_one_voxel_sets_one_voxel():
    tri = np.array([[[3.2, 4.1, 1.3], [3.8, 4.2, 1.6], [3.4, 4.9, 1.2]]])
    assert as_set(voxelize(tri, Grid(UNIT, 1.0, 8))) == {(3, 4, 1)}


def test_world_grid_scales_and_offsets():
    # the same triangle in world units (voxel 0.25, origin -1): the same voxels
    tri = np.array([[[3.2, 4.1, 1.3], [3.8, 4.2, 1.6], [3.4, 4.9, 1.2]]])
    assert as_set(voxelize(tri * 0.25 - 1.0, Grid((-1.0, -1.0, -1.0), 0.25, 8))) == {(3, 4, 1)}


def test_cube_grid_contains_the_box():
    g = cube_grid([-1, 0, 2], [3, 1, 2.5], 16)
    assert g.extent == pytest.approx(4 * 1.001)
    np.testing.assert_allclose(np.array(g.origin) + g.extent / 2, [1, 0.5, 2.25])


def test_chunking_does_not_change_the_set():
    rng = np.random.default_rng(7)
    tris = np.concatenate([rng.uniform(0, 32, (40, 3, 3)), rng.uniform(0, 32, 3) + rng.normal(0, 0.3, (200, 3, 3))])
    g = Grid(UNIT, 1.0, 32)
    a, b = voxelize(tris, g), voxelize(tris, g, chunk=1)  # chunk 1: clamped to 32^2, big triangles cut in slabs
    assert np.array_equal(a.ids, b.ids)
    assert np.all(np.diff(a.ids) > 0)  # sorted, unique


def test_degenerate_and_outside_triangles():
    g = Grid(UNIT, 1.0, 8)
    segment = np.array([[[0.5, 0.5, 0.5], [2.5, 0.5, 0.5], [1.5, 0.5, 0.5]]])  # zero area, along x
    assert as_set(voxelize(segment, g)) == {(0, 0, 0), (1, 0, 0), (2, 0, 0)}
    outside = np.array([[[20.0, 20, 20], [21, 20, 20], [20, 21, 20]]])
    assert voxelize(outside, g).count == 0


def test_huge_coordinates_stay_finite():
    g = cube_grid([-1e6, -1e6, -1e6], [1e6, 1e6, 1e6], 16)
    tri = np.array([[[-1e6, -1e6, 0.0], [1e6, -1e6, 0.0], [0.0, 1e6, 0.0]]])
    v = voxelize(tri, g)
    assert 0 < v.count <= 2 * 16 * 16 and set(np.unique(v.coords()[:, 2])) == {7, 8}


def test_budget_guard():
    tris = quad(0.3, 5.3, 1.2, 4.7, 2.25)
    with pytest.raises(VoxelBudgetError, match="resolution 8"):
        voxelize(tris, Grid(UNIT, 1.0, 8), max_candidates=10)


def test_ids_are_row_major():
    assert list(ids_of(np.array([[1, 2, 3]]), 8)) == [(1 * 8 + 2) * 8 + 3]


def test_sphere_shell_between_its_bounds():
    # the builtin sphere's polyhedron lies between radius cos(pi / 64) (its faces' inner bound, generously
    # 0.99) and 1 (its vertices): a voxel box wholly outside radius 1 or wholly inside 0.99 must be empty, a
    # box reaching both inside 0.99 and outside 1 must be set (it crosses the closed surface)
    m = meshes.sphere(32)
    g = cube_grid([-1, -1, -1], [1, 1, 1], 24)
    got = voxelize(compare.triangles_of(m.positions, m.indices), g)
    lo = np.array(g.origin) + np.array(list(np.ndindex(24, 24, 24))) * g.voxel
    hi = lo + g.voxel
    nearest = np.linalg.norm(np.clip(0.0, lo, hi), axis=1)
    farthest = np.linalg.norm(np.maximum(np.abs(lo), np.abs(hi)), axis=1)
    ids = np.arange(24 ** 3)
    must = ids[(nearest < 0.99) & (farthest > 1.0)]
    never = ids[(nearest > 1.0) | (farthest < 0.99)]
    assert np.isin(must, got.ids).all() and not np.isin(never, got.ids).any()
    assert len(must) > 500
