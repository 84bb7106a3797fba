"""Diffuse precomputed radiance transfer, numpy + Embree half (realtime/techniques/prt/prt_transfer.py).

Each expectation comes from somewhere else than the code under test: Gauss-Legendre quadrature of the
defining integrals (in a frame of the test's own), the geometry of a half-space occluder, the
configuration factors of an integrating sphere (and Lambert's contour formula for its polygonal
opening), and exact equality where the math says the Monte Carlo part vanishes.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import trimesh
from numpy.polynomial import legendre

from realtime.engine.transfer_rays import EPSILON_FRACTION
from realtime.techniques.prt import prt_transfer as prt
from realtime.techniques.prt.prt_transfer import TransferObject, cached_transfer, transfer
from scenes.environment.shbasis import count, sh_basis
from scenes.storage.disk_cache import CacheWarning

ORDERS = [2, 3, 4]


def mesh_object(m: trimesh.Trimesh, kd=(0.8, 0.8, 0.8)) -> TransferObject:
    return TransferObject(np.asarray(m.vertices, dtype=np.float64), np.asarray(m.vertex_normals, dtype=np.float64),
                          np.asarray(m.faces), kd)


def gauss_cap(n: np.ndarray, n_theta: int = 48, n_phi: int = 96, theta_max: float = np.pi / 2):
    """Directions (N, 3) and solid-angle weights (N,) over the cap {angle to n <= theta_max}: Gauss-Legendre
    in theta (the integrands here are analytic in theta) x uniform phi, in a frame built here."""
    n = n / np.linalg.norm(n)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t = helper - (helper @ n) * n
    t /= np.linalg.norm(t)
    b = np.cross(n, t)
    x, w = legendre.leggauss(n_theta)
    theta, wt = 0.5 * theta_max * (x + 1), 0.5 * theta_max * w
    phi = 2 * np.pi * (np.arange(n_phi) + 0.5) / n_phi
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    d = (st * np.cos(phi))[..., None] * t + (st * np.sin(phi))[..., None] * b + np.repeat(ct, n_phi, 1)[..., None] * n
    weights = (wt * np.sin(theta))[:, None] * np.full(n_phi, 2 * np.pi / n_phi)
    return d.reshape(-1, 3), weights.ravel()


# -------------------------------------------------------------------------------- 1. convex objects


@pytest.mark.parametrize("shape", ["icosphere", "box"])
@pytest.mark.parametrize("order", ORDERS)
def test_convex_object_shadowed_equals_unshadowed_exactly(shape, order):
    # the tangent plane of a vertex normal inside the normal cone supports a convex object: no ray hits,
    # so the control variate subtracts nothing
    m = trimesh.creation.icosphere(subdivisions=3) if shape == "icosphere" else trimesh.creation.box((1, 2, 3))
    obj = mesh_object(m)
    shadowed = transfer([obj], order, rays=64, bounces=0, shadowed=True, seed=3)[0]
    unshadowed = transfer([obj], order, rays=64, bounces=0, shadowed=False)[0]
    assert shadowed.shape == (len(obj.positions), count(order), 3) and shadowed.dtype == np.float32
    assert np.array_equal(shadowed, unshadowed)


# -------------------------------------------------------------------------------- 2. unshadowed


NORMALS = [(0, 0, 1), (0, -1, 0), (1, 0, 0), (0.3, -0.5, 0.8), (-0.7, 0.1, -0.2)]


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("normal", NORMALS)
def test_unshadowed_transfer_is_the_clamped_cosine_integral(order, normal):
    # int Y_k(w) max(n.w, 0) dw by quadrature over the hemisphere about n (no A_l involved)
    n = np.asarray(normal, dtype=np.float64)
    n /= np.linalg.norm(n)
    d, w = gauss_cap(n)
    expected = np.einsum("ik,i->k", sh_basis(d, order), w * (d @ n))
    tri = TransferObject(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.repeat(n[None], 3, 0),
                         np.array([[0, 1, 2]]), (0.5, 0.5, 0.5))
    t = transfer([tri], order, rays=1, bounces=0, shadowed=False)[0]
    for c in range(3):
        np.testing.assert_allclose(t[0, :, c], expected, rtol=0, atol=1e-4)
        assert np.array_equal(t[:, :, c], t[:, :, 0])  # the same for every channel and vertex


# -------------------------------------------------------------------------------- 3. half-space occluder

D, S, W = 1.0, 0.05, 100.0  # floor patch centre x, half-size; wall half-size
GRID = 6  # floor vertices per side


def quad_grid(corner, du, dv, n: int, normal, kd=(0.5, 0.5, 0.5)) -> TransferObject:
    """An n x n vertex grid corner + i du + j dv, two triangles per cell wound counter-clockwise about du x dv."""
    i, j = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    p = np.asarray(corner, float) + i[..., None] * np.asarray(du, float) + j[..., None] * np.asarray(dv, float)
    k = np.arange(n * n).reshape(n, n)
    a, b, c, d = k[:-1, :-1].ravel(), k[1:, :-1].ravel(), k[1:, 1:].ravel(), k[:-1, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return TransferObject(p.reshape(-1, 3), np.tile(np.asarray(normal, float), (n * n, 1)), faces, kd)


def wall_and_floor() -> tuple[TransferObject, TransferObject]:
    # wall x = 0, |y|, |z| <= W, facing +x; floor patch y = 0 around (D, 0, 0), facing +y
    wall = quad_grid((0, -W, -W), (0, 2 * W, 0), (0, 0, 2 * W), 2, (1, 0, 0))
    floor = quad_grid((D - S, 0, -S), (0, 0, 2 * S), (2 * S, 0, 0), GRID, (0, 1, 0))
    return wall, floor


def wall_integral(o: np.ndarray, g, n: int = 128) -> np.ndarray:
    """int over the directions from o that meet the wall above o's horizon (y > o_y) of g(w) dw: the
    wall rectangle x = 0, o_y < y < W, |z| < W, parametrised by y = o_y + o_x tan(a), z = o_z + o_x tan(b)
    (dw = cos(angle) dA / r^2 = o_x dA / r^3; smooth in a, b: Gauss-Legendre, converged to 1e-13 at n = 128)."""
    x, w = legendre.leggauss(n)

    def nodes(lo, hi):
        return 0.5 * (hi - lo) * x + 0.5 * (hi + lo), 0.5 * (hi - lo) * w

    a, wa = nodes(0.0, np.arctan((W - o[1]) / o[0]))
    b, wb = nodes(np.arctan((-W - o[2]) / o[0]), np.arctan((W - o[2]) / o[0]))
    ta, tb = np.tan(a)[:, None], np.tan(b)[None, :]
    p = np.stack(np.broadcast_arrays(np.zeros_like(ta * tb), o[1] + o[0] * ta, o[2] + o[0] * tb), -1)
    r = p - o
    dist = np.linalg.norm(r, axis=-1)
    jac = o[0] ** 2 / np.cos(a)[:, None] ** 2 / np.cos(b)[None, :] ** 2  # dy dz = o_x^2 sec^2 a sec^2 b da db
    vals = g(r / dist[..., None])
    return np.einsum("ijk,ij->k", vals, (wa[:, None] * wb[None, :]) * jac * o[0] / dist**3)


@pytest.mark.parametrize("order", ORDERS)
def test_half_space_occluder_leaves_the_half_hemisphere_away_from_the_wall(order):
    rays = 4096
    wall, floor = wall_and_floor()
    t = transfer([wall, floor], order, rays=rays, bounces=0, shadowed=True, seed=7)[1].astype(np.float64)
    assert np.array_equal(t[..., 1], t[..., 0]) and np.array_equal(t[..., 2], t[..., 0])
    t = t[..., 0]
    up = np.array([0.0, 1.0, 0.0])
    d, w = gauss_cap(up, n_theta=64, n_phi=256)
    y = sh_basis(d, order)
    hemisphere = np.einsum("ik,i->k", y, w * d[:, 1])  # the unshadowed transfer
    ideal = np.einsum("ik,i->k", y, w * d[:, 1] * (d[:, 0] > 0))  # {w_y > 0, w_x > 0}; phi nodes avoid w_x = 0
    # the finite wall: exactly what it hides above each vertex's horizon (ray origin raised by eps)
    eps = EPSILON_FRACTION * np.linalg.norm([D + S, 2 * W, 2 * W])
    expected = np.array([hemisphere - wall_integral(p + eps * up, lambda u: sh_basis(u, order) * u[..., 1:2])
                         for p in floor.positions])
    assert np.abs(expected - ideal).max() < 0.01  # a wall 100 x the distance is nearly the half-space
    # Monte Carlo tolerance: sigma = the plain-MC standard deviation of one vertex's occluded part per
    # coefficient, sqrt((pi int_occ Y_k^2 cos - (int_occ Y_k cos)^2) / R), an upper bound for the stratified
    # (rotated-lattice) estimator; each vertex within 4 sigma, the mean of the N independent vertices within
    # 4 sigma / sqrt(N) (~1 % of the occluded part of T_00); one fixed seed
    occluded = d[:, 0] < 0
    second = np.pi * np.einsum("ik,i->k", y**2, w * d[:, 1] * occluded)
    sigma = np.sqrt((second - (hemisphere - ideal) ** 2) / rays)
    assert (np.abs(t - expected) < 4 * sigma).all()
    assert (np.abs((t - expected).mean(axis=0)) < 4 * sigma / np.sqrt(len(t))).all()
    # in particular T_00 is half the unshadowed one
    assert abs(t[:, 0].mean() / hemisphere[0] - 0.5) < (4 * sigma[0] / np.sqrt(len(t))) / hemisphere[0] + 0.01


# -------------------------------------------------------------------------------- 3b. one gathering bounce

CEILING_HALF, CEILING_Y = 1.5, 1.0
CEILING_KD = (0.9, 0.6, 0.3)


def ceiling_and_floor(facing_down: bool) -> tuple[TransferObject, TransferObject]:
    # a ceiling quad (y = 1) with shading normals tilted 35 degrees from -y in four azimuths, so that its
    # transfer varies strongly from vertex to vertex; a small floor patch below, off centre
    a, h = CEILING_HALF, CEILING_Y
    tilt, az = np.radians(35.0), np.radians([20.0, 140.0, 230.0, 320.0])
    n = np.stack([np.sin(tilt) * np.cos(az), np.full(4, -np.cos(tilt)), np.sin(tilt) * np.sin(az)], 1)
    faces = np.array([[0, 1, 2], [0, 2, 3]])  # (b - a) x (c - a) = -y: facing down
    ceiling = TransferObject(np.array([[-a, h, -a], [a, h, -a], [a, h, a], [-a, h, a]]), n,
                             faces if facing_down else faces[:, ::-1], CEILING_KD)
    floor = quad_grid((0.25, 0, -0.25), (0, 0, 0.1), (0.1, 0, 0), 2, (0, 1, 0))
    return ceiling, floor


@pytest.mark.parametrize("facing_down", [True, False])
def test_one_bounce_gathers_the_interpolated_transfer_of_front_faces(facing_down):
    rays = 4096
    ceiling, floor = ceiling_and_floor(facing_down)
    t0 = transfer([ceiling, floor], 2, rays, 0, True, seed=4)
    t1 = transfer([ceiling, floor], 2, rays, 1, True, seed=4)
    gathered = (t1[1] - t0[1]).astype(np.float64)  # the same rays: T^1 of the floor
    if not facing_down:  # the floor sees the ceiling's back: black, nothing gathered
        assert np.array_equal(t1[1], t0[1])
        return
    # expected: (1 / pi) int over the ceiling of kd T^0(y) cos cos' / r^2 dA, T^0 the ceiling's own
    # (returned) transfer interpolated linearly over its two triangles; midpoint rule on a fine grid
    src = t0[0].astype(np.float64) * np.asarray(CEILING_KD)  # (4, 9, 3)
    n = 600
    u = -CEILING_HALF + 2 * CEILING_HALF * (np.arange(n) + 0.5) / n
    x, z = (a.ravel() for a in np.meshgrid(u, u, indexing="ij"))
    # bilinear coordinates s, r in [0, 1] along +x, +z; triangle (0, 1, 2) is r <= s, (0, 2, 3) is r >= s
    s, r = (x + CEILING_HALF) / (2 * CEILING_HALF), (z + CEILING_HALF) / (2 * CEILING_HALF)
    lower = (r <= s)[:, None, None]
    interp = np.where(lower, (1 - s)[:, None, None] * src[0] + (s - r)[:, None, None] * src[1]
                      + r[:, None, None] * src[2],
                      (1 - r)[:, None, None] * src[0] + s[:, None, None] * src[2] + (r - s)[:, None, None] * src[3])
    eps = EPSILON_FRACTION * np.linalg.norm(ceiling.positions.max(0) - np.minimum(ceiling.positions.min(0),
                                                                                      floor.positions.min(0)))
    for v, p in enumerate(floor.positions):
        o = p + [0.0, eps, 0.0]
        dy = CEILING_Y - o[1]
        weight = dy**2 / ((x - o[0]) ** 2 + dy**2 + (z - o[2]) ** 2) ** 2 * (2 * CEILING_HALF / n) ** 2 / np.pi
        expected = np.einsum("p,pkc->kc", weight, interp)
        # plain-MC sigma of (1 / R) sum kd T^0(y_j) under the cosine density; 4 sigma per value
        sigma = np.sqrt((np.einsum("p,pkc->kc", weight, interp**2) - expected**2) / rays)
        assert (np.abs(gathered[v] - expected) < 4 * sigma + 1e-6).all()


# -------------------------------------------------------------------------------- 3c. colour of the bounces

OCCLUDER_KD = (0.9, 0.5, 0.2)  # the three channels distinct, so a swap or a shared channel shows
GROUND_KD = (0.3, 0.6, 0.8)  # neither proportional to the occluder's nor grey: products differ from both


def ball_over_ground() -> tuple[TransferObject, TransferObject, np.ndarray, np.ndarray]:
    """A sphere (radius 0.5) just above a ground square (half size 1.5, facing +y); (sphere, ground, the
    albedo each vertex's first bounce gathers: the other object's, the albedo of its second bounce: both)."""
    m = trimesh.creation.icosphere(subdivisions=2, radius=0.5)
    m.apply_translation((0.0, 0.55, 0.0))
    ball = mesh_object(m, kd=OCCLUDER_KD)
    ground = quad_grid((-1.5, 0, -1.5), (0, 0, 3.0), (3.0, 0, 0), 9, (0, 1, 0), kd=GROUND_KD)
    first = np.concatenate([np.tile(GROUND_KD, (len(ball.positions), 1)),
                            np.tile(OCCLUDER_KD, (len(ground.positions), 1))])
    second = np.tile(np.multiply(OCCLUDER_KD, GROUND_KD), (len(ball.positions) + len(ground.positions), 1))
    return ball, ground, first, second


@pytest.fixture(scope="module")
def coloured_bounces() -> list[np.ndarray]:
    ball, ground = ball_over_ground()[:2]
    return [np.concatenate(transfer([ball, ground], 2, 64, b, True, seed=9)).astype(np.float64) for b in (0, 1, 2)]


def test_shadowed_transfer_is_the_same_in_every_channel(coloured_bounces):
    """Visibility does not depend on colour: without bounces the three channels of T are equal (exactly:
    one estimate, copied), whatever the objects' albedos."""
    t0 = coloured_bounces[0]
    assert np.array_equal(t0[..., 1], t0[..., 0]) and np.array_equal(t0[..., 2], t0[..., 0])


@pytest.mark.parametrize("bounce", [1, 2])
def test_each_bounce_is_tinted_by_the_albedos_it_gathered_through(coloured_bounces, bounce):
    """A sphere over a plane: the plane's rays can only hit the sphere and the sphere's only the plane
    (each is convex or flat), so the b-th bounce term T^b = T(b) - T(b - 1) of a vertex is a channel-free
    quantity times the product of the albedos along its path: channel c of T^1 scales with the OTHER
    object's kd_c, channel c of T^2 with kd_sphere,c x kd_plane,c, for every SH coefficient (the
    gathering is linear and the shadowed transfer is grey). Ratio test across channels, independent of
    the geometry; a swapped, shared or receiver's albedo, or one bounce too many or too few, breaks it."""
    ball, ground, first, second = ball_over_ground()
    tint = first if bounce == 1 else second
    term = coloured_bounces[bounce] - coloured_bounces[bounce - 1]  # (V, 9, 3)
    grey = term / tint[:, None, :]  # the channel-free quantity, three times
    # float32 storage of T(b) and T(b - 1): a few ulps of the whole transfer
    atol = 4 * np.finfo(np.float32).eps * np.abs(coloured_bounces[bounce]).max()
    for c in (1, 2):
        np.testing.assert_allclose(grey[..., c], grey[..., 0], rtol=0, atol=atol / tint.min())
    # negative control: the bounce is well above the tolerance, and the same term tinted the other way
    # round (red and blue swapped) would be told apart
    big = np.abs(term[:, 0, 0]) > 100 * atol
    assert big.sum() > 20
    swapped = term[..., ::-1] / tint[:, None, :]
    assert np.abs(swapped[big, 0, 0] - swapped[big, 0, 1]).min() > 10 * atol / tint.min()


# -------------------------------------------------------------------------------- 4. integrating sphere

RHO = 0.8


def open_sphere(subdivisions: int = 3, cut: float = 0.6):
    """Inside of a unit icosphere (inward winding and normals) without the faces whose centroid has y > cut;
    returns (object, removed area fraction, exact per-vertex opening form factors, boundary mask)."""
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    keep = v[f].mean(axis=1)[:, 1] <= cut
    f_area = m.area_faces[~keep].sum() / m.area_faces.sum()
    f = f[keep]
    used = np.unique(f)
    remap = np.full(len(v), -1)
    remap[used] = np.arange(len(used))
    v, f = v[used], remap[f][:, ::-1]  # inward winding
    n = -v / np.linalg.norm(v, axis=1, keepdims=True)
    # directed boundary edges (their reverse belongs to no kept face): the rim of the opening
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    have = set(map(tuple, edges))
    rim = np.array([e for e in edges if (e[1], e[0]) not in have])
    boundary = np.zeros(len(v), dtype=bool)
    boundary[rim.ravel()] = True
    # Lambert's contour formula: the form factor from (x, n) to a surface bounded by the rim loop is
    # |sum_edges angle_i (n . unit(r_i x r_i+1))| / 2 pi (every opening direction leaves through the
    # removed faces of the convex full polyhedron exactly once)
    x = v[~boundary]
    r0, r1 = v[rim[:, 0]][None] - x[:, None], v[rim[:, 1]][None] - x[:, None]
    c = np.cross(r0, r1)
    angle = np.arctan2(np.linalg.norm(c, axis=-1), np.einsum("vei,vei->ve", r0, r1))
    ff = np.full(len(v), np.nan)
    ff[~boundary] = np.abs(np.einsum("ve,vei,vi->v", angle, c / np.linalg.norm(c, axis=-1, keepdims=True),
                                     n[~boundary])) / (2 * np.pi)
    return TransferObject(v, n, f, (RHO, RHO, RHO)), f_area, ff, boundary


@pytest.fixture(scope="module")
def furnace():
    obj, f_area, ff, boundary = open_sphere()
    rays = 1024
    # constant environment L_e = 1: only L_00 = 2 sqrt(pi) is nonzero, so E = L_00 T_00
    energy = {b: 2 * np.sqrt(np.pi) * transfer([obj], 2, rays, b, True, seed=11)[0][:, 0, :].astype(np.float64)
              for b in (0, 1, 2, 4)}
    return obj, f_area, ff, boundary, energy


def series(f: float, bounces: int) -> float:
    """E_B / (pi L_e) of a sphere with opening fraction f: f sum_{b=0..B} (rho (1 - f))^b."""
    return f * sum((RHO * (1 - f)) ** b for b in range(bounces + 1))


@pytest.mark.parametrize("bounces", [0, 1, 2, 4])
def test_integrating_sphere_follows_the_bounce_series(furnace, bounces):
    obj, f_area, ff, boundary, energy = furnace
    away = obj.positions[:, 1] < 0.3  # away from the rim (y ~ 0.6)
    f_exact = ff[away].mean()
    # discretisation: the inscribed polyhedron's removed-area fraction is the sphere's configuration factor
    # up to O(edge^2); the contour form factor is the mesh's own (and varies by < spread over the vertices)
    assert abs(f_area - f_exact) < 0.005 * f_exact
    spread = np.nanmax(np.abs(ff - f_exact))
    e = energy[bounces][away] / np.pi
    assert np.array_equal(e[:, 1], e[:, 0]) and np.array_equal(e[:, 2], e[:, 0])
    # Monte Carlo: independent per-vertex rotations, so the standard error of the mean is std / sqrt(N);
    # discretisation: the series moved by the spread of the exact form factors
    se = e[:, 0].std() / np.sqrt(len(e))
    disc = max(abs(series(f_exact + s, bounces) - series(f_exact, bounces)) for s in (spread, -spread))
    assert abs(e[:, 0].mean() - series(f_exact, bounces)) < 4 * se + disc
    assert abs(e[:, 0].mean() - series(f_area, bounces)) < 4 * se + disc + abs(series(f_area, bounces)
                                                                                 - series(f_exact, bounces))


def test_integrating_sphere_grows_with_bounces_below_the_infinite_series(furnace):
    obj, f_area, ff, boundary, energy = furnace
    e = [energy[b][:, 0] / np.pi for b in (0, 1, 2, 4)]
    for lo, hi in itertools.pairwise(e):
        assert (hi > lo).all()  # same rays, non-negative gathered terms; every vertex sees walls
    limit = f_area / (1 - RHO * (1 - f_area))  # infinitely many bounces
    away = obj.positions[:, 1] < 0.3
    assert e[-1][away].mean() < limit and e[-1].max() < limit


# -------------------------------------------------------------------------------- 5. determinism, cache


def torus_object(kd=(0.7, 0.5, 0.3)) -> TransferObject:
    return mesh_object(trimesh.creation.torus(1.0, 0.4, major_sections=24, minor_sections=12), kd=kd)


def test_same_seed_same_transfer_other_seed_other_noise():
    obj = torus_object()
    a = transfer([obj], 3, 64, 1, True, seed=5)[0]
    b = transfer([obj], 3, 64, 1, True, seed=5)[0]
    c = transfer([obj], 3, 64, 1, True, seed=6)[0]
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    assert not np.array_equal(a[..., 0], a[..., 2])  # kd differs per channel: so do the bounces


def test_chunking_does_not_change_the_result(monkeypatch):
    obj = torus_object()
    whole = transfer([obj], 2, 64, 2, True, seed=1)[0]
    monkeypatch.setattr(prt, "MAX_RAYS_PER_CHUNK", 64 * 7)  # 7 vertices per chunk
    assert np.array_equal(transfer([obj], 2, 64, 2, True, seed=1)[0], whole)


def test_cache_second_call_is_cached_and_identical(tmp_path, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))
    objs = [torus_object(), mesh_object(trimesh.creation.box((0.5, 0.5, 0.5)))]
    first, info1 = cached_transfer(objs, 2, 32, 1, True, seed=2)
    second, info2 = cached_transfer(objs, 2, 32, 1, True, seed=2)
    assert not info1["cached"] and info2["cached"] and info2["seconds"] == 0 and info1["seconds"] > 0
    assert info1["key"] == info2["key"] and (tmp_path / "prt" / f"{info1['key']}.npz").is_file()
    vertices = sum(len(o.positions) for o in objs)
    assert info1["vertices"] == info2["vertices"] == vertices
    assert info1["rays_traced"] == info2["rays_traced"] == 32 * vertices
    for a, b, c in zip(first, second, transfer(objs, 2, 32, 1, True, seed=2), strict=True):
        assert np.array_equal(a, b) and np.array_equal(a, c)
    assert cached_transfer(objs, 2, 32, 0, False)[1]["rays_traced"] == 0


@pytest.mark.parametrize("change", [{"rays": 33}, {"bounces": 2}, {"seed": 3}, {"order": 3}, {"shadowed": False,
                                    "bounces": 0}, "kd", "two_sided", "positions", "normals", "indices"])
def test_cache_key_changes_with_every_input(change):
    obj = torus_object()
    args = {"order": 2, "rays": 32, "bounces": 1, "shadowed": True, "seed": 2}
    base = prt.transfer_key([obj], **args)
    if isinstance(change, dict):
        assert prt.transfer_key([obj], **{**args, **change}) != base
        return
    if change == "kd":
        other = TransferObject(obj.positions, obj.normals, obj.indices, (0.7, 0.5, 0.31))
    elif change == "two_sided":
        other = TransferObject(obj.positions, obj.normals, obj.indices, obj.kd, two_sided=True)
    elif change == "positions":
        other = TransferObject(obj.positions + 1e-6, obj.normals, obj.indices, obj.kd)
    elif change == "normals":
        other = TransferObject(obj.positions, -obj.normals, obj.indices, obj.kd)
    else:
        other = TransferObject(obj.positions, obj.normals, obj.indices[:, ::-1], obj.kd)
    assert prt.transfer_key([other], **args) != base


@pytest.mark.parametrize("damage", ["garbage", "truncated", "other_array"])
def test_corrupt_cache_entry_is_recomputed_with_a_warning(tmp_path, monkeypatch, damage):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))
    obj = torus_object()
    good, info = cached_transfer([obj], 2, 16, 0, True)
    path = tmp_path / "prt" / f"{info['key']}.npz"
    if damage == "garbage":
        path.write_bytes(b"not a zip file")
    elif damage == "truncated":
        path.write_bytes(path.read_bytes()[:200])
    else:  # a well-formed entry whose arrays are not the ones its checksum covers
        with np.load(path) as z:
            entry = dict(z)
        entry["t0"] = entry["t0"] + 1
        with open(path, "wb") as f:
            np.savez(f, **entry)
    with pytest.warns(CacheWarning, match="corrupt"):
        again, info2 = cached_transfer([obj], 2, 16, 0, True)
    assert not info2["cached"] and np.array_equal(again[0], good[0])
    assert cached_transfer([obj], 2, 16, 0, True)[1]["cached"]  # rewritten


def test_unwritable_cache_is_a_warning(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("a file where the cache folder should be")
    monkeypatch.setenv("IBLCHECK_CACHE", str(blocker))
    obj = torus_object()
    with pytest.warns(CacheWarning, match="cannot be written"):
        t, info = cached_transfer([obj], 2, 16, 0, True)
    assert not info["cached"] and np.array_equal(t[0], transfer([obj], 2, 16, 0, True)[0])


def test_progress_goes_to_stderr(capsys):
    transfer([torus_object()], 2, 16, 0, True, progress=True)
    assert capsys.readouterr().out == ""


# -------------------------------------------------------------------------------- 6. bad input


@pytest.mark.parametrize("order", [0, 1, 9])
def test_unsupported_order_is_refused(order):
    with pytest.raises(ValueError, match=f"order must be 2..8.*got {order}"):
        transfer([torus_object()], order, 16, 0, True)


@pytest.mark.parametrize("field", ["positions", "normals"])
def test_non_finite_input_names_the_object(field):
    good = torus_object()
    arr = getattr(good, field).copy()
    arr[5, 1] = np.nan
    bad = TransferObject(**{**vars(good), field: arr})
    for shadowed in (False, True):
        with pytest.raises(ValueError, match=f"object 1: {field} contain NaN"):
            transfer([good, bad], 2, 16, 0, shadowed)
        with pytest.raises(ValueError, match=f"object 1: {field} contain NaN"):
            cached_transfer([good, bad], 2, 16, 0, shadowed)


@pytest.mark.parametrize("kwargs, message", [
    ({"bounces": 1, "shadowed": False}, "needs shadowed"),
    ({"rays": 0}, "rays must be"),
    ({"bounces": -1}, "bounces must be"),
])
def test_inconsistent_settings_are_refused(kwargs, message):
    args = {"order": 2, "rays": 16, "bounces": 0, "shadowed": True, **kwargs}
    with pytest.raises(ValueError, match=message):
        transfer([torus_object()], **args)


def test_bad_indices_are_refused():
    good = torus_object()
    bad = TransferObject(good.positions, good.normals, good.indices + len(good.positions), good.kd)
    with pytest.raises(ValueError, match="object 0: triangle indices out of range"):
        transfer([bad], 2, 16, 0, True)
