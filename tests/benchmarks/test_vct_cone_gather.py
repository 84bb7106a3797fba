"""The parts of benchmarks/vct_cone_gather.py against answers known by construction: the cone's and the cosine
lobe's directions by their mean cosines, the voxels' radiance lookup on a hand-made grid, the exact cone integral
and the exact direct light by ray casting planes and a closed box whose answers follow from symmetry, and on the
GPU the injected radiance of a lone convex sphere under a constant environment (visibility 1 everywhere)."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import scenes
from realtime.techniques.vct import vct_math
from scenes.environment.shbasis import sh9
from scenes.geometry.meshes import BOWL_INNER, bowl, bowl_centre
from scenes.model.camera import Camera

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
def test_cap_directions_fill_the_cap_uniformly_in_solid_angle(half_deg):
    """Uniform over a cap of half-angle a: every direction within a of the axis and the mean cosine (1 + cos a)/2
    (the mean of cos theta over sin theta d theta on [0, a]). Control: directions uniform in theta instead
    (too many near the axis) fail the same bound."""
    a = math.radians(half_deg)
    axes = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    n = 20000
    d = vct_math.cap_directions(axes, a, n, np.random.default_rng(1))
    cos = np.einsum("kcj,kj->kc", d, axes)
    assert np.allclose(np.linalg.norm(d, axis=-1), 1.0)
    assert cos.min() >= math.cos(a) - 1e-12
    expected = 0.5 * (1.0 + math.cos(a))
    bound = 5.0 * (1.0 - math.cos(a)) / math.sqrt(12.0 * n)  # cos uniform on [cos a, 1]: its standard error
    assert np.abs(cos.mean(1) - expected).max() < bound
    uniform_theta = np.cos(a * np.random.default_rng(2).random(n))
    assert abs(uniform_theta.mean() - expected) > bound


def test_cosine_directions_have_the_cosine_lobes_mean_cosine():
    """Density cos / pi over the hemisphere: unit directions, none below it, E[cos] = 2/3, and across the normal
    E[(d . t)^2] = 1/4. Control: directions uniform over the hemisphere (cos uniform in [0, 1], mean 1/2) fail the
    same bound."""
    normals = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    d = model.cosine_directions(normals, 20000, np.random.default_rng(2))
    cos = np.einsum("pcj,pj->pc", d, normals)
    assert np.allclose(np.linalg.norm(d, axis=-1), 1.0)
    assert cos.min() >= 0.0
    bound = 5.0 * math.sqrt(1.0 / 18.0 / 20000)  # cos has variance 1/2 - 4/9 under cos / pi
    assert np.abs(cos.mean(1) - 2.0 / 3.0).max() < bound
    # across the normal: E[(d . t)^2] = (1 - E[cos^2]) / 2 = 1/4 for any tangent t (E[cos^2] = 1/2)
    tangent = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    assert np.abs((np.einsum("pcj,pj->pc", d, tangent) ** 2).mean(1) - 0.25).max() < 0.01
    assert abs(np.random.default_rng(3).random(20000).mean() - 2.0 / 3.0) > bound


def test_voxel_radiance_reads_the_face_toward_the_normal_in_its_own_voxel_first():
    """An 8^3 grid (voxel 0.5 from 0) whose voxel (3, 4, 5) has its +Y face half covered showing 0.6 and whose
    voxel (3, 5, 5) above it has its +Y face fully covered showing 0.2. A point in the upper voxel with normal +y
    reads its own voxel, 0.2, though the lower one is also near; with that voxel's face emptied it reads the
    neighbour, 0.6 (rgb / coverage); with normal -y it reads the empty -Y faces, 0; three voxels away, 0."""
    f = np.zeros((6, 8, 8, 8, 4), dtype=np.float32)
    f[2, 3, 4, 5] = [0.3, 0.3, 0.3, 0.5]
    f[2, 3, 5, 5] = [0.2, 0.2, 0.2, 1.0]
    lo, h = np.zeros(3), 0.5
    upper = np.array([[3.5 * h, 5.5 * h, 5.5 * h]])
    far = np.array([[3.5 * h, 7.9 * h, 5.5 * h]])
    up, down = np.array([[0.0, 1.0, 0.0]]), np.array([[0.0, -1.0, 0.0]])
    assert model.voxel_radiance(f, lo, h, upper, up)[0] == pytest.approx(0.2)
    assert model.voxel_radiance(f, lo, h, upper, down)[0] == 0.0
    f[2, 3, 5, 5] = 0.0
    assert model.voxel_radiance(f, lo, h, upper, up)[0] == pytest.approx(0.6)
    assert model.voxel_radiance(f, lo, h, far, up)[0] == 0.0


@pytest.mark.parametrize("inward", [True, False])
def test_a_cone_inside_a_closed_box_meets_it_everywhere_and_gathers_its_fronts(inward):
    """From the centre of a closed cube every direction meets a wall: share 1. Walls whose fronts face inward show
    the grid's radiance 0.7 to the cone; the control, fronts facing out, shows their backs: 0, share still 1."""
    tris = box(1.0, inward)
    ray = model.scene_intersector(tris)
    faces = lit_grid(8, 0.7)
    axes = np.array([[0.0, 0.0, 1.0], [0.6, 0.8, 0.0]])
    dirs = vct_math.cap_directions(axes, math.radians(33.6), 400, np.random.default_rng(3))
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
    dirs = vct_math.cap_directions(axes, a, 4000, np.random.default_rng(4))
    _, share = model.exact_cones(ray, tris, lit_grid(4, 1.0), np.full(3, -1.0), 0.5,
                                 np.array([[0.0, 1e-3, 0.0]] * 2), dirs, 1e-7)
    assert share[0] == pytest.approx(0.5, abs=0.03)  # 4000 directions: standard error 0.008
    assert share[1] == 0.0


def linear_sky(a: float, b: float) -> np.ndarray:
    """SH9 radiance coefficients (9, 3) of L(w) = a + b w_y (bands 0 and 1 of shbasis.sh9: Y_00 = C0,
    Y_1-1 = C1 y)."""
    coeffs = np.zeros((9, 3))
    coeffs[0] = a / sh9(np.array([0.0, 1.0, 0.0]))[0]
    coeffs[1] = b / sh9(np.array([0.0, 1.0, 0.0]))[1]
    return coeffs


@pytest.mark.parametrize("normal", [(0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.6, 0.8)])
def test_exact_direct_light_under_a_linear_sky(normal):
    """Under L(w) = a + b w_y an unshadowed point of normal n receives int L cos = pi (a + 2 b n_y / 3) (the
    cosine lobe's mean direction is 2 n / 3), so its direct radiance is kd (a + 2 b n_y / 3) and its visibility 1.
    Control: directions uniform over the hemisphere would give kd (a + b n_y / 2), outside the bound where
    n_y != 0."""
    a, b, kd = 1.0, 0.8, np.array([[0.5, 0.6, 0.7]])
    n = np.array([normal])
    # a small plane toward (-1, -1, -1), behind every normal's hemisphere: the intersector needs a triangle
    behind = triangles([quad([(-5.5, -5, -5.5), (-4.5, -5, -5.5), (-4.5, -5, -4.5), (-5.5, -5, -4.5)], (0, 1, 0))])
    direct, v = model.exact_direct(model.scene_intersector(behind), np.zeros((1, 3)), n, kd,
                                   model.sh9_sky(linear_sky(a, b)),
                                   20000, 1e-6, np.random.default_rng(5))
    expected = kd.mean() * (a + 2.0 * b * n[0, 1] / 3.0)
    bound = 5.0 * kd.mean() * b / math.sqrt(20000)
    assert v[0] == 1.0
    assert abs(direct[0] - expected) < bound
    if n[0, 1] != 0.0:
        assert abs(kd.mean() * (a + b * n[0, 1] / 2.0) - expected) > bound


def test_a_roof_shadows_the_direct_light():
    """Under a roof 1 above the point and 10^4 wide the point sees the sky only within 1/5000 rad of its horizon
    (a cosine-weighted share under 1e-7): no direct light. Control: the same point above the roof sees it all."""
    roof = triangles([quad([(-5e3, 1, -5e3), (5e3, 1, -5e3), (5e3, 1, 5e3), (-5e3, 1, 5e3)], (0, -1, 0))])
    ray = model.scene_intersector(roof)
    up, kd = np.array([[0.0, 1.0, 0.0]]), np.array([[0.5, 0.5, 0.5]])
    sky = model.sh9_sky(linear_sky(1.0, 0.0))
    direct, v = model.exact_direct(ray, np.zeros((1, 3)), up, kd, sky, 2000, 1e-6, np.random.default_rng(6))
    assert v[0] == 0.0 and direct[0] == 0.0
    direct, v = model.exact_direct(ray, np.array([[0.0, 2.0, 0.0]]), up, kd, sky, 2000, 1e-6,
                                   np.random.default_rng(6))
    assert v[0] == 1.0 and direct[0] == pytest.approx(0.5)


def test_exact_irradiance_of_a_uniformly_lit_closed_box_is_pi_times_its_radiance():
    """Inside a closed cube whose every face shows 0.7, every direction meets a front: the irradiance is
    pi 0.7. Control: fronts facing out, the rays meet backs and gather 0."""
    faces = lit_grid(8, 0.7)
    points, normals = np.zeros((2, 3)), np.array([[0.0, 1.0, 0.0], [0.6, 0.0, 0.8]])
    for inward, expected in ((True, math.pi * 0.7), (False, 0.0)):
        tris = box(1.0, inward)
        e = model.exact_irradiance(model.scene_intersector(tris), tris, faces, np.full(3, -2.0), 0.5, points,
                                   normals, 500, 1e-6, np.random.default_rng(8))
        assert e == pytest.approx([expected, expected], rel=1e-6, abs=1e-9)  # the faces are float32


# Inside a sphere of radius R two points x, y of its surface see each other along the chord d = y - x, and the
# chord makes the same angle with both inward normals: cos(theta_x) = cos(theta_y) = |d| / (2R). The form factor's
# kernel cos(theta_x) cos(theta_y) / (pi |d|^2) is then 1 / (4 pi R^2) for every pair, and the irradiance at x
# from a Lambertian radiance L over the part S of the sphere x sees is (1 / 4R^2) int_S L dA. A chord between
# two points of a hemispherical bowl's inside stays inside the ball, so every point of the inside sees all of it
# and gathers the same bounce, however the light is spread over the inside (benchmarks/vct_cone_gather.py's
# --bands reads VCT's gather against it on bowl-diffuse).
BOWL_CENTRE = bowl_centre()


def bowl_triangles() -> model.Triangles:
    """meshes.bowl's triangles, one-sided, as the benchmark builds a scene's."""
    return model.scene_triangles([SimpleNamespace(mesh=bowl(), material=SimpleNamespace(two_sided=False))])


def inner_facet(tris: model.Triangles, polar_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The centroid and normal of the bowl's inner facet nearest the direction `polar_deg` from its bottom (at
    azimuth 37 deg): a point on the mesh itself, which lies a hair inside the sphere."""
    t, a = math.radians(polar_deg), math.radians(37.0)
    want = BOWL_CENTRE + BOWL_INNER * np.array([math.sin(t) * math.sin(a), -math.cos(t), math.sin(t) * math.cos(a)])
    centroids = tris.vertices.mean(1)
    inner = np.einsum("fj,fj->f", tris.normals, BOWL_CENTRE - centroids) > 0.9 * BOWL_INNER
    i = np.flatnonzero(inner)[np.argmin(np.linalg.norm(centroids[inner] - want, axis=1))]
    return centroids[i], tris.normals[i]


def depth_lit_grid(res: int, lo: float, voxel: float, base: float, slope: float) -> np.ndarray:
    """Faces (6, R, R, R, 4), every face opaque, showing base + slope (c_y - y) / R_inner at its texel's centre
    (y its height): brighter toward the bowl's bottom."""
    y = lo + (np.arange(res) + 0.5) * voxel
    value = base + slope * (BOWL_CENTRE[1] - y) / BOWL_INNER
    f = np.zeros((6, res, res, res, 4), dtype=np.float32)
    f[..., :3] = value[None, None, :, None, None]
    f[..., 3] = 1.0
    return f


@pytest.mark.parametrize("slope", [0.0, 1.0])
@pytest.mark.parametrize("polar_deg", [3.0, 30.0, 60.0, 85.0])
def test_every_point_inside_a_hemispherical_bowl_gathers_the_same_bounce(polar_deg, slope):
    """The radiance base + slope (c_y - y) / R over the bowl's inside: int_S L dA = 2 pi R^2 base + pi R^2 slope
    (the lower hemisphere's int -u_y dA is pi R^2), so every inner point gathers (pi / 2) base + (pi / 4) slope
    (the derivation above), by ray casting within 3 % at the bottom, half way and near the rim (measured within
    1.2 %); the next test is its control."""
    tris = bowl_triangles()
    voxel, lo = 0.05, -1.0
    faces = depth_lit_grid(40, lo, voxel, 0.5, slope)
    expected = math.pi / 2 * 0.5 + math.pi / 4 * slope
    point, normal = inner_facet(tris, polar_deg)
    e = model.exact_irradiance(model.scene_intersector(tris), tris, faces, np.full(3, lo), voxel, point[None],
                               normal[None], 4096, 1e-5, np.random.default_rng(3))
    assert e[0] == pytest.approx(expected, rel=0.03)


@pytest.mark.parametrize("slope", [0.0, 1.0])
def test_a_point_off_the_bowls_sphere_does_not_gather_the_same_bounce(slope):
    """The control of the test above: the kernel is constant only between points of the sphere. A point a third
    of the radius up from the bottom toward the centre, facing up, sees more of the opening: below 0.9 of the
    inner points' bounce (measured 0.47-0.62)."""
    tris = bowl_triangles()
    voxel, lo = 0.05, -1.0
    bottom, _ = inner_facet(tris, 0.0)
    lifted = bottom + np.array([0.0, BOWL_INNER / 3.0, 0.0])
    e = model.exact_irradiance(model.scene_intersector(tris), tris, depth_lit_grid(40, lo, voxel, 0.5, slope),
                               np.full(3, lo), voxel, lifted[None], np.array([[0.0, 1.0, 0.0]]), 4096, 1e-5,
                               np.random.default_rng(3))
    assert e[0] < 0.9 * (math.pi / 2 * 0.5 + math.pi / 4 * slope)


def toward(azimuth_deg: float, elevation_deg: float, distance: float = 2.0) -> np.ndarray:
    """A point `distance` from the origin, `azimuth_deg` toward +x and `elevation_deg` toward +y off -z."""
    a, e = math.radians(azimuth_deg), math.radians(elevation_deg)
    return distance * np.array([math.sin(a) * math.cos(e), math.sin(e), -math.cos(a) * math.cos(e)])


def test_camera_weights_count_the_pixels_a_unit_of_area_covers():
    """Camera at the origin looking down -z, vertical fov 70 deg, an image twice as wide as high (horizontal
    half-fov atan(2 tan 35 deg) = 54.5 deg): a point 2 away on the axis facing it covers 1/4 (up to the constant);
    turned 60 deg, 1/8; facing the camera 30 deg or 45 deg off the axis sideways, or 30 deg upward, 1/4 over
    cos^3 of that angle; 60 deg sideways or 40 deg upward (out of view), facing away, or behind the camera, 0."""
    camera = Camera(origin=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0), fov_deg=70.0, width=200, height=100)
    ahead = toward(0.0, 0.0)
    turned = np.array([math.sin(math.radians(60.0)), 0.0, math.cos(math.radians(60.0))])
    offsets = [(30.0, 0.0), (45.0, 0.0), (0.0, 30.0), (60.0, 0.0), (0.0, 40.0)]
    points = np.array([ahead, ahead, *[toward(a, e) for a, e in offsets], ahead, -ahead])
    normals = np.array([[0.0, 0.0, 1.0], turned, *[-toward(a, e, 1.0) for a, e in offsets], [0.0, 0.0, -1.0],
                        [0.0, 0.0, -1.0]])
    far = triangles([quad([(-5, -5, -50), (5, -5, -50), (5, 5, -50), (-5, 5, -50)], (0, 0, 1))])
    w = model.camera_weights(model.scene_intersector(far), points, normals, camera, 1e-6)
    off = [0.25 / math.cos(math.radians(x)) ** 3 for x in (30.0, 45.0, 30.0)]
    assert w == pytest.approx([0.25, 0.125, *off, 0.0, 0.0, 0.0, 0.0])


@pytest.mark.parametrize(("wall_z", "expected"), [(-1.0, 0.0), (1.0, 0.25), (-3.0, 0.25)])
def test_only_what_lies_between_a_point_and_the_camera_hides_it(wall_z, expected):
    """A wall across the view at z = -1, between the camera at the origin and the point at z = -2, hides it;
    behind the camera (z = 1) or behind the point (z = -3) it does not."""
    camera = Camera(origin=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0))
    wall = triangles([quad([(-1, -1, wall_z), (1, -1, wall_z), (1, 1, wall_z), (-1, 1, wall_z)], (0, 0, 1))])
    w = model.camera_weights(model.scene_intersector(wall), np.array([[0.0, 0.0, -2.0]]),
                             np.array([[0.0, 0.0, 1.0]]), camera, 1e-6)
    assert w[0] == pytest.approx(expected)


def test_a_point_under_a_lit_ceiling_gathers_its_direct_light():
    """A one-sided ceiling 10^4 wide, 1 above a point facing up, its front down, kd 0.6, lit from below by a
    constant sky of 1.5 that nothing else shadows: its direct radiance is kd 1.5, and the point, whose whole
    hemisphere it fills (but for 1/5000 rad at the horizon), gathers pi kd 1.5. The voxels hold 0.9 there: the
    point gathers pi 0.9 of them over the same rays. Control: the ceiling's front turned up, the rays meet its
    back and gather nothing."""
    sky = model.sh9_sky(linear_sky(1.5, 0.0))
    faces = lit_grid(8, 0.9)
    for front, expected in (((0, -1, 0), 1.0), ((0, 1, 0), 0.0)):
        roof = triangles([quad([(-5e3, 1, -5e3), (5e3, 1, -5e3), (5e3, 1, 5e3), (-5e3, 1, 5e3)], front)])
        injected, (direct,) = model.gathered_direct(
            model.scene_intersector(roof), roof, np.array([[0.6, 0.6, 0.6]]), faces, np.array([-1e4, 0.5, -1e4]),
            2.5e3, np.zeros((1, 3)), np.array([[0.0, 1.0, 0.0]]), [sky], 256, 64, 1e-6, np.random.default_rng(9))
        assert direct[0] == pytest.approx(expected * math.pi * 0.6 * 1.5, rel=1e-6, abs=1e-9)
        assert injected[0] == pytest.approx(expected * math.pi * 0.9, rel=1e-6, abs=1e-9)


def test_height_bands_split_the_range_into_equal_bands():
    """Heights 0..1 into 4 bands: 0.1 in the first, 0.3 in the second, 0.5 in the third, 0.9 and the top 1.0 in
    the last; every height in exactly one band."""
    h = np.array([0.0, 0.1, 0.3, 0.5, 0.9, 1.0])
    edges, bands = model.height_bands(h, 4)
    assert edges == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0])
    assert [np.flatnonzero(b).tolist() for b in bands] == [[0, 1], [2], [3], [4, 5]]
    assert sum(b.astype(int) for b in bands).tolist() == [1] * 6


def two_object_rows(camera_weight: np.ndarray, gathered: tuple[np.ndarray, np.ndarray, np.ndarray]
                    ) -> model.ConeRows:
    """Two objects of two points each (heights 0, 1, 2, 3), every cone reading half the exact cone integral on the
    first and all of it on the second, each exact integral 1 and the hemisphere pi; power weights 1 and 3."""
    w = np.full(model.CONES, math.pi / model.CONES)
    ids = np.array([0, 0, 1, 1])
    vct = np.repeat([[0.5], [0.5], [1.0], [1.0]], model.CONES, axis=1)
    ones = np.ones((4, model.CONES))
    per_point = np.ones(4)
    points = np.c_[np.zeros(4), np.arange(4.0), np.zeros(4)]
    return model.ConeRows(ids, vct, ones, ones, ones, w, np.full(4, math.pi), per_point, per_point, per_point,
                          vct[:, 0] * math.pi, per_point, per_point, np.array([1.0, 1.0, 3.0, 3.0]), points,
                          camera_weight, *gathered)


def test_summary_weights_the_cones_and_the_objects():
    """The read 0.5 and 1.0 (no spread: standard error 0), the quadrature 1 on both; "all" weighs the points by
    their power weights: (0.5 + 3) / 4 = 0.875. No point seen by the camera: no row "seen", no product line."""
    rows = two_object_rows(np.zeros(4), (np.zeros(4), np.zeros(4), np.zeros(4)))
    lines = model.summary(rows, ["a", "b"], injection=False)
    assert len(lines) == 5
    assert lines[2].startswith("| a | 0.500 ± 0.000 | 1.000 ± 0.000 | 0.500 ± 0.000 |")
    assert lines[3].startswith("| b | 1.000 ± 0.000 | 1.000 ± 0.000 | 1.000 ± 0.000 |")
    assert lines[4].startswith("| all | 0.875 ±")
    assert len(model.summary(rows, ["a", "b"], injection=True)) == 5 + 6


def test_the_seen_row_weighs_the_points_as_the_camera_sees_them():
    """The camera sees the first object's points with weight 3 and one of the second's with weight 1: the row
    "seen" reads (3 0.5 + 1) / 4 = 0.625. The points gather injected 1.2 where the exact direct light under SH9
    gives 1.0 and under the map 0.8 (on every seen point), so the product line reads 0.625 x 1.2 x 1.25 = 0.9375;
    an unseen point's values (here 100) do not count."""
    gathered = (np.array([1.2, 1.2, 1.2, 100.0]), np.array([1.0, 1.0, 1.0, 100.0]),
                np.array([0.8, 0.8, 0.8, 1.0]))
    rows = two_object_rows(np.array([1.5, 1.5, 1.0, 0.0]), gathered)
    lines = model.summary(rows, ["a", "b"], injection=True)
    assert lines[5].startswith("| seen | 0.625 ±")
    assert lines[-1].startswith("seen by the camera")
    assert "read x quadrature 0.625 x injection 1.200" in lines[-1]
    assert "SH9 over the map 1.250 = 0.938" in lines[-1]


def test_band_lines_read_vct_over_exact_by_height():
    """Two bands over heights 0..3: the first holds the first object's points (VCT 0.5 of the exact), the second
    the second's (1.0); where no point gathers any bounce, one line says so."""
    rows = two_object_rows(np.zeros(4), (np.zeros(4), np.zeros(4), np.zeros(4)))
    lines = model.band_lines(rows, 2)
    assert lines[2] == "| 0.000 to 1.500 | 2 | 3.1416 | 0.500 |"
    assert lines[3] == "| 1.500 to 3.000 | 2 | 3.1416 | 1.000 |"
    dark = model.ConeRows(**{**rows.__dict__, "exact_irradiance": np.zeros(4)})
    assert model.band_lines(dark, 2) == ["no point gathers a bounce: no bands"]


@pytest.mark.gl
@pytest.mark.parametrize(("environment", "per_point"), [("builtin:constant", 0.02), ("builtin:uffizi", 0.12)])
def test_a_lone_convex_spheres_injected_radiance_is_its_exact_direct_light(environment, per_point):
    """A convex object alone sees the whole sky from every point: the exact visibility is 1, the exact direct
    light kd / pi E(n) (the cast's estimate over all points within 2 % of it), and the injection's kd / pi E V_d
    with V_d = 1 is the same per point but for the normal E is taken at: a voxel's face evaluates it at its
    surfaces' mean normal (measured 1.000 under a constant sky, 0.905-1.101 under Uffizi at 32^3). Control: the
    lookup's face taken against the normal, the sphere's inside, holds no light."""
    scene = scenes.load("builtin:sphere-diffuse").with_overrides({"environment.map": environment})
    vs, coeffs, irradiance = model.voxelise(scene, 32)
    try:
        faces, lo, h = model.level0_faces(vs), model.grid_lower_corner(vs), vs.grid.voxel_size
    finally:
        vs.release()
    rng = np.random.default_rng(7)
    tris = model.scene_triangles(scene.objects)
    points, normals, ids = model.surface_points(tris, 64, rng)
    albedo = np.array([scene.objects[i].material.kd for i in ids], dtype=np.float64)
    direct, v = model.exact_direct(model.scene_intersector(tris), points, normals, albedo, model.sh9_sky(coeffs),
                                   256, model.ray_offset(tris), rng)
    n4 = np.c_[normals, np.ones(len(points))]
    analytic = (albedo / math.pi * np.einsum("pi,cij,pj->pc", n4, irradiance, n4)).mean(1)
    assert (v == 1.0).all()
    assert direct.sum() == pytest.approx(analytic.sum(), rel=0.02)
    ratio = model.voxel_radiance(faces, lo, h, points, normals) / analytic
    assert np.abs(ratio - 1.0).max() < per_point, ratio
    assert (model.voxel_radiance(faces, lo, h, points, -normals) == 0.0).all()


@pytest.mark.gl
def test_the_benchmarks_cones_are_the_shadings_cones():
    """gather traces each cone from the origin and with the frame it builds itself; the cosine-weighted sum of
    its cones must be the irradiance the shader's own diffuse cone set gathers at the same points
    (VoxelScene.probe), to float rounding. Control: the same cones with their weights reversed (the axis's weight
    on a ring cone) do not."""
    scene = scenes.load("builtin:cornell-open").with_overrides(
        {"objects.6.material": {"type": "diffuse", "kd": [0.0, 0.0, 0.0]}})
    rows = model.gather(scene, 32, per_object=8, rays=32, seed=3)
    assert np.allclose(rows.vct_radiance @ rows.weights, rows.probe_irradiance, rtol=1e-3, atol=1e-6)
    assert not np.allclose(rows.vct_radiance @ rows.weights[::-1], rows.probe_irradiance, rtol=1e-3, atol=1e-6)
