"""The parts of benchmarks/vct_cone_gather.py against answers known by construction: the cone's and the cosine
lobe's directions by their mean cosines, the voxels' radiance lookup on a hand-made grid, the exact cone integral
and the exact direct light by ray casting planes and a closed box whose answers follow from symmetry, and on the
GPU the injected radiance of a lone convex sphere under a constant environment (visibility 1 everywhere)."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

import scenes
from scenes.environment.shbasis import sh9

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("vct_cone_gather", ROOT / "benchmarks" / "vct_cone_gather.py")
model = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(model)


def quad(corners: list[tuple[float, float, float]], facing: tuple[float, float, float]):
    """Two triangles of the quad with these four corners (in order around it), wound so that their geometric
    normal points along `facing`: (vertices (2, 3, 3), their unit normals (2, 3))."""
    c = np.array(corners, dtype=np.float64)
    tris = np.array([[c[0], c[1], c[2]], [c[0], c[2], c[3]]])
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    if n[0] @ np.array(facing) < 0.0:
        tris = tris[:, ::-1]
        n = -n
    return tris, n / np.linalg.norm(n, axis=1, keepdims=True)


def triangles(quads: list, two_sided: bool = False) -> model.Triangles:
    v = np.concatenate([q[0] for q in quads])
    n = np.concatenate([q[1] for q in quads])
    return model.Triangles(v, n, np.zeros(len(v), dtype=np.int32), np.array([two_sided]))


def box(half: float, inward: bool) -> model.Triangles:
    """The six faces of the cube [-half, half]^3, their fronts inward or outward."""
    quads = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u, w = [a for a in range(3) if a != axis]
            corners = []
            for du, dw in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u], p[w] = sign * half, du * half, dw * half
                corners.append(tuple(p))
            out = [0.0, 0.0, 0.0]
            out[axis] = sign
            quads.append(quad(corners, tuple(-x for x in out) if inward else tuple(out)))
    return triangles(quads)


def lit_grid(res: int, radiance: float) -> np.ndarray:
    """Faces (6, R, R, R, 4) of a grid whose every face is opaque and shows `radiance` (premultiplied)."""
    f = np.zeros((6, res, res, res, 4), dtype=np.float32)
    f[..., :3] = radiance
    f[..., 3] = 1.0
    return f


@pytest.mark.parametrize("half_deg", [10.0, 33.6])
def test_cone_directions_fill_the_cap_uniformly_in_solid_angle(half_deg):
    """Uniform over a cap of half-angle a: every direction within a of the axis and the mean cosine (1 + cos a)/2
    (the cap's mean of cos theta over sin theta d theta). Control: the mean differs from a cap twice as wide's
    by many standard errors."""
    a = math.radians(half_deg)
    axes = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    d = model.cone_directions(axes, a, 20000, np.random.default_rng(1))
    cos = np.einsum("kcj,kj->kc", d, axes)
    assert np.allclose(np.linalg.norm(d, axis=-1), 1.0)
    assert cos.min() >= math.cos(a) - 1e-12
    expected = 0.5 * (1.0 + math.cos(a))
    standard_error = (1.0 - math.cos(a)) / math.sqrt(12.0 * 20000)
    assert np.abs(cos.mean(1) - expected).max() < 5.0 * standard_error
    assert abs(cos.mean() - 0.5 * (1.0 + math.cos(2.0 * a))) > 50.0 * standard_error


def test_cosine_directions_have_the_cosine_lobes_mean_cosine():
    """Density cos / pi over the hemisphere: E[cos] = 2/3, none below it; a uniform hemisphere's 1/2 is far."""
    n = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    d = model.cosine_directions(n, 20000, np.random.default_rng(2))
    cos = np.einsum("pcj,pj->pc", d, n)
    assert cos.min() >= 0.0
    assert np.abs(cos.mean(1) - 2.0 / 3.0).max() < 0.01
    assert abs(cos.mean() - 0.5) > 0.1


def test_voxel_radiance_reads_the_face_toward_the_normal_in_the_most_covered_neighbour():
    """One voxel (3, 4, 5) of an 8^3 grid (voxel 0.5 from 0) whose +Y face is half covered and shows 0.6: a point
    in the voxel above it with normal +y reads 0.6 (the neighbour search, and rgb / coverage); with normal -y it
    reads the empty -Y face, 0; a point three voxels away reads 0."""
    f = np.zeros((6, 8, 8, 8, 4), dtype=np.float32)
    f[2, 3, 4, 5] = [0.3, 0.3, 0.3, 0.5]
    lo, h = np.zeros(3), 0.5
    above = np.array([[3.5 * h, 5.5 * h, 5.5 * h]])
    far = np.array([[3.5 * h, 7.5 * h, 5.5 * h]])
    up, down = np.array([[0.0, 1.0, 0.0]]), np.array([[0.0, -1.0, 0.0]])
    assert model.voxel_radiance(f, lo, h, above, up)[0] == pytest.approx(0.6)
    assert model.voxel_radiance(f, lo, h, above, down)[0] == 0.0
    assert model.voxel_radiance(f, lo, h, far, up)[0] == 0.0


@pytest.mark.parametrize("inward", [True, False])
def test_a_cone_inside_a_closed_box_meets_it_everywhere_and_gathers_its_fronts(inward):
    """From the centre of a closed cube every direction meets a wall: share 1. Walls whose fronts face inward show
    the grid's radiance 0.7 to the cone; the control, fronts facing out, shows their backs: 0, share still 1."""
    tris = box(1.0, inward)
    ray = model.scene_intersector(tris)
    faces = lit_grid(8, 0.7)
    axes = np.array([[0.0, 0.0, 1.0], [0.6, 0.8, 0.0]])
    dirs = model.cone_directions(axes, math.radians(33.6), 400, np.random.default_rng(3))
    radiance, share = model.exact_cones(ray, tris, faces, np.full(3, -2.0), 0.5, np.zeros((2, 3)), dirs, 1e-6)
    assert share == pytest.approx([1.0, 1.0])
    assert radiance == pytest.approx([0.7, 0.7] if inward else [0.0, 0.0], abs=1e-6)


def test_a_cone_along_a_large_plane_is_half_blocked():
    """A cone whose axis runs level a thousandth above a plane 10^4 wide: by symmetry half its directions point
    down and meet the plane (but for those within 1e-3 / 5000 rad of level). Control: the cone turned up by more
    than its half-angle meets nothing."""
    tris = triangles([quad([(-5e3, 0, -5e3), (5e3, 0, -5e3), (5e3, 0, 5e3), (-5e3, 0, 5e3)], (0, 1, 0))])
    ray = model.scene_intersector(tris)
    a = math.radians(20.0)
    axes = np.array([[1.0, 0.0, 0.0], [math.cos(0.4), math.sin(0.4), 0.0]])
    dirs = model.cone_directions(axes, a, 4000, np.random.default_rng(4))
    _, share = model.exact_cones(ray, tris, lit_grid(4, 1.0), np.full(3, -1.0), 0.5,
                                 np.array([[0.0, 1e-3, 0.0]] * 2), dirs, 1e-7)
    assert share[0] == pytest.approx(0.5, abs=0.03)  # 4000 directions: standard error 0.008
    assert share[1] == 0.0


def test_exact_direct_light_under_a_constant_sky_and_under_a_roof():
    """A constant environment L (SH9: c00 = L / Y00): an open point's direct radiance is kd L and its visibility 1;
    under a roof 1 above it and 10^4 wide it sees almost nothing (the sky below 1/5000 rad of its horizon: a
    cosine-weighted share under 1e-7)."""
    L, kd = 2.0, np.array([[0.5, 0.6, 0.7]])
    coeffs = np.zeros((9, 3))
    coeffs[0] = L / sh9(np.array([0.0, 0.0, 1.0]))[0]
    roof = triangles([quad([(-5e3, 1, -5e3), (5e3, 1, -5e3), (5e3, 1, 5e3), (-5e3, 1, 5e3)], (0, -1, 0))])
    ray = model.scene_intersector(roof)
    up = np.array([[0.0, 1.0, 0.0]])
    open_point = np.array([[0.0, 2.0, 0.0]])  # above the roof: nothing above it
    direct, v = model.exact_direct(ray, open_point, up, kd, coeffs, 2000, 1e-6, np.random.default_rng(5))
    assert v[0] == 1.0 and direct[0] == pytest.approx(kd.mean() * L)
    direct, v = model.exact_direct(ray, np.zeros((1, 3)), up, kd, coeffs, 2000, 1e-6, np.random.default_rng(6))
    assert v[0] == 0.0 and direct[0] == 0.0


def test_summary_weights_the_cones_and_keeps_the_objects_apart():
    """Two points on two objects, every cone reading half the exact radiance on the first and all of it on the
    second: E ratios 0.5 and 1.0, and for both 2 / 3 (weights w sum pi, exact radiance 1 on each)."""
    w = np.full(model.CONES, math.pi / model.CONES)
    ones = np.ones((2, model.CONES))
    rows = model.ConeRows(np.array([0, 1]), np.array([[0.5] * model.CONES, [1.0] * model.CONES]), ones, ones, ones,
                          w, np.array([1.0, 1.0]), np.array([2.0, 1.0]), np.array([1.0, 1.0]))
    lines = model.summary(rows, ["a", "b"])
    assert lines[2].startswith("| a | 0.500 |") and "| 0.500 | 1.000 |" in lines[2]
    assert lines[3].startswith("| b | 1.000 |")
    assert lines[4].startswith("| all | 0.750 |") and "| 0.667 | 1.000 |" in lines[4]


@pytest.mark.gl
def test_a_lone_convex_spheres_injected_radiance_is_its_exact_direct_light_under_a_constant_sky():
    """A convex object alone sees the whole sky from every point: the injection's kd / pi E V_d is kd L exactly
    (E = pi L, V_d = 1), as is the exact direct light the benchmark casts (measured 1.000 at 32^3). Control: the
    lookup's face taken against the normal, the sphere's inside, holds no light."""
    scene = scenes.load("builtin:sphere-diffuse").with_overrides({"environment.map": "builtin:constant"})
    vs, coeffs, _ = model.voxelise(scene, 32)
    try:
        faces, lo, h = vs.read_faces(0)[:, 0], model.grid_lower_corner(vs), vs.grid.voxel_size
    finally:
        vs.release()
    rng = np.random.default_rng(7)
    tris = model.scene_triangles(scene.objects)
    points, normals, ids = model.surface_points(tris, 64, rng)
    albedo = np.array([scene.objects[i].material.kd for i in ids], dtype=np.float64)
    direct, v = model.exact_direct(model.scene_intersector(tris), points, normals, albedo, coeffs, 256,
                                   model.ray_offset(tris), rng)
    assert (v == 1.0).all()
    ratio = model.voxel_radiance(faces, lo, h, points, normals) / direct
    assert np.abs(ratio - 1.0).max() < 0.02, ratio
    assert (model.voxel_radiance(faces, lo, h, points, -normals) == 0.0).all()
