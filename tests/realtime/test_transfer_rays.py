"""The shared rays of precomputed transfer (realtime/engine/transfer_rays.py), against expectations derived here:

- the hemisphere directions have density cos / pi: E[cos] = 2/3, E[cos^2] = 1/2 and the second moment
  E[d d^T] = (I - n n^T) / 4 + n n^T / 2 (E[sin^2] = 1/2 split evenly between the two tangents);
- the Fibonacci lattice: the first coordinate is the R midpoints, the second has the three-gap property of
  frac(j / phi) (Steinhaus' theorem: at most three distinct gaps, all > 0);
- the frames are orthonormal and right-handed with the normal as third axis, at the poles too;
- any-hit visibility of a unit quad equals the analytic ray / plane test, from either side;
- the gather's row of a point under a centred square equals the square's point-to-plane form factor
  (Howell's catalogue, B-3), lands its hit points on the square's plane, and is zero for a back face;
- the object checks name the object and what is wrong.
Each with a negative control: a deliberately wrong variant the same check rejects.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from realtime.engine import transfer_rays as tr

R = 4096
#: a lattice's sample mean of a smooth function of the first coordinate errs by O(1 / R); 8 / R bounds it
MOMENT_TOL = 8.0 / R


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


NORMALS = {"up": [0, 0, 1], "down": [0, 0, -1], "x": [1, 0, 0], "oblique": [0.3, -0.5, 0.8],
           "south pole 1e-9": [1e-9, 0, -1], "equator": [0.6, 0.8, 0.0], "just below equator": [0.6, 0.8, -1e-12]}


def moment_problems(d: np.ndarray, n: np.ndarray) -> list[str]:
    """What makes directions d (R, 3) about unit n not cosine-distributed unit vectors (empty: nothing)."""
    problems = []
    if np.abs(np.linalg.norm(d, axis=1) - 1.0).max() > 1e-12:
        problems.append("not unit")
    cos = d @ n
    if cos.min() <= 0.0:
        problems.append("below the hemisphere")
    if abs(cos.mean() - 2.0 / 3.0) > MOMENT_TOL:
        problems.append(f"E[cos] = {cos.mean():.5f}, not 2/3")
    if abs((cos ** 2).mean() - 0.5) > MOMENT_TOL:
        problems.append(f"E[cos^2] = {(cos ** 2).mean():.5f}, not 1/2")
    want = (np.eye(3) - np.outer(n, n)) / 4.0 + np.outer(n, n) / 2.0
    second = d.T @ d / len(d)
    if np.abs(second - want).max() > MOMENT_TOL:
        problems.append(f"E[d d^T] off by {np.abs(second - want).max():.5f}")
    return problems


@pytest.mark.parametrize("name", NORMALS)
def test_directions_are_cosine_distributed(name):
    n = unit(NORMALS[name])
    shift = np.random.default_rng(3).random((1, 2))
    d = tr.directions(n[None], shift, tr.lattice(R))[0]
    assert moment_problems(d, n) == []


@pytest.mark.parametrize("wrong", ["uniform hemisphere", "about the flipped normal", "azimuth over pi"])
def test_directions_negative_controls(wrong):
    n = unit(NORMALS["oblique"])
    u = np.mod(tr.lattice(R) + np.random.default_rng(3).random(2), 1.0)
    t, b = tr.frames(n[None])
    t, b = t[0], b[0]
    phi = 2.0 * np.pi * u[:, 1]
    if wrong == "uniform hemisphere":  # z uniform in (0, 1]: density 1 / (2 pi), E[cos] = 1/2
        z = 1.0 - u[:, 0]
    else:
        z = np.sqrt(1.0 - u[:, 0])
    if wrong == "azimuth over pi":
        phi = np.pi * u[:, 1]
    r = np.sqrt(1.0 - z ** 2)
    d = (r * np.cos(phi))[:, None] * t + (r * np.sin(phi))[:, None] * b + z[:, None] * n
    if wrong == "about the flipped normal":
        d = tr.directions(-n[None], np.random.default_rng(3).random((1, 2)), tr.lattice(R))[0]
    assert moment_problems(d, n) != []


def lattice_problems(points: np.ndarray) -> list[str]:
    rays = len(points)
    problems = []
    if points.min() < 0.0 or points.max() >= 1.0:
        problems.append("outside [0, 1)^2")
    if not np.allclose(np.sort(points[:, 0]), (np.arange(rays) + 0.5) / rays, rtol=0, atol=1e-15):
        problems.append("first coordinate not the midpoints")
    ys = np.sort(points[:, 1])
    gaps = np.diff(np.concatenate([ys, [ys[0] + 1.0]]))  # circular gaps
    distinct = np.unique(np.round(gaps * rays, 6))
    if gaps.min() <= 0.0 or len(distinct) > 3:
        problems.append(f"{len(distinct)} distinct gaps, smallest {gaps.min():.3g}")
    return problems


@pytest.mark.parametrize("rays", [1, 2, 13, 64, 100, 4096])
def test_lattice_is_stratified_and_three_gap(rays):
    assert lattice_problems(tr.lattice(rays)) == []


@pytest.mark.parametrize("generator", [0.5, 0.3])  # rational generators: repeated points (gap 0)
def test_lattice_negative_control(generator):
    j = np.arange(64, dtype=np.float64)
    assert lattice_problems(np.stack([(j + 0.5) / 64, np.mod(j * generator, 1.0)], axis=1)) != []


def frame_problems(t: np.ndarray, b: np.ndarray, n: np.ndarray) -> list[str]:
    problems = []
    basis = np.stack([t, b, n], axis=1)  # (V, 3 axes, 3)
    gram = basis @ np.swapaxes(basis, 1, 2)
    if np.abs(gram - np.eye(3)).max() > 1e-12:
        problems.append(f"not orthonormal (off by {np.abs(gram - np.eye(3)).max():.3g})")
    if np.abs(np.cross(t, b) - n).max() > 1e-12 or (np.linalg.det(basis) <= 0).any():
        problems.append("not right-handed with n as the third axis")
    return problems


def frame_normals() -> np.ndarray:
    rng = np.random.default_rng(11)
    return np.concatenate([unit(list(NORMALS.values())), unit(rng.normal(size=(2000, 3)))])


def test_frames_are_orthonormal_and_right_handed():
    n = frame_normals()
    t, b = tr.frames(n)
    assert frame_problems(t, b, n) == []


@pytest.mark.parametrize("wrong", ["swapped tangents", "tilted tangent"])
def test_frames_negative_controls(wrong):
    n = frame_normals()
    t, b = tr.frames(n)
    if wrong == "swapped tangents":
        t, b = b, t
    else:
        t = unit(t + 1e-6 * n)
    assert frame_problems(t, b, n) != []


def quad(facing: str) -> tuple[np.ndarray, np.ndarray]:
    """The unit square [0, 1]^2 at z = 1, counter-clockwise seen from its front (facing -z or +z)."""
    p = np.array([[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=np.float64)
    f = np.array([[0, 1, 2], [0, 2, 3]]) if facing == "up" else np.array([[0, 2, 1], [0, 3, 2]])
    return p, f


def random_rays(seed: int = 5, count: int = 4000) -> tuple[np.ndarray, np.ndarray]:
    """Rays from z = 0 (below the quad) and z = 2 (above): half toward all directions, half aimed at points of
    [-0.5, 1.5]^2 on the quad's plane (so that about a quarter of those hit)."""
    rng = np.random.default_rng(seed)
    o = np.column_stack([rng.uniform(-1, 2, count), rng.uniform(-1, 2, count), rng.choice([0.0, 2.0], count)])
    target = np.column_stack([rng.uniform(-0.5, 1.5, count), rng.uniform(-0.5, 1.5, count), np.ones(count)])
    d = np.where((np.arange(count) % 2 == 0)[:, None], rng.normal(size=(count, 3)), target - o)
    return o, unit(d)


def analytic_blocked(o: np.ndarray, d: np.ndarray, x_max: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(blocked, clear of the edges): the ray reaches the plane z = 1 at t > 0 inside [0, x_max] x [0, 1]."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (1.0 - o[:, 2]) / d[:, 2]
    hit = o + t[:, None] * d
    forward = np.isfinite(t) & (t > 0)
    inside = forward & (hit[:, 0] >= 0) & (hit[:, 0] <= x_max) & (hit[:, 1] >= 0) & (hit[:, 1] <= 1)
    edge = np.minimum.reduce([np.abs(hit[:, 0]), np.abs(hit[:, 0] - x_max), np.abs(hit[:, 1]),
                              np.abs(hit[:, 1] - 1)])
    return inside, ~forward | (edge > 1e-6)


@pytest.mark.parametrize("facing", ["up", "down"])
def test_any_hit_visibility_of_a_unit_quad(facing):
    p, f = quad(facing)
    o, d = random_rays()
    blocked, clear = analytic_blocked(o, d)
    seen = tr.visible(tr.intersector(p, f, "test"), o, d)
    assert blocked[clear].sum() > 300 and (~blocked[clear]).sum() > 300  # both outcomes are exercised
    assert np.array_equal(seen[clear], ~blocked[clear])


@pytest.mark.parametrize("wrong", ["front faces only", "a quad twice as wide"])
def test_any_hit_visibility_negative_controls(wrong):
    p, f = quad("up")
    o, d = random_rays()
    seen = tr.visible(tr.intersector(p, f, "test"), o, d)
    blocked, clear = analytic_blocked(o, d, x_max=2.0 if wrong == "a quad twice as wide" else 1.0)
    if wrong == "front faces only":  # facing +z: only rays going down (d . face normal < 0) would be blocked
        blocked = blocked & (d[:, 2] < 0)
    assert not np.array_equal(seen[clear], ~blocked[clear])


def test_visibility_of_no_rays_is_empty():
    p, f = quad("up")
    assert tr.visible(tr.intersector(p, f, "test"), np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)


def point_to_square_form_factor(a: float, h: float) -> float:
    """Form factor from a point to a parallel square of half side a centred h above it: four corner
    rectangles, each an element to a parallel rectangle over its corner (Howell's catalogue, B-3), A = B = a / h:
    F = 4 / (2 pi) x 2 A / sqrt(1 + A^2) atan(A / sqrt(1 + A^2))."""
    x = (a / h) / math.sqrt(1.0 + (a / h) ** 2)
    return 4.0 / math.pi * x * math.atan(x)


def point_under_square(a: float, h: float, facing: str):
    """Vertex 0 at the origin (normal +z) and a square of half side a at height h (vertices 1..4)."""
    p = np.array([[0, 0, 0], [-a, -a, h], [a, -a, h], [a, a, h], [-a, a, h]], dtype=np.float64)
    n = np.array([[0, 0, 1]] + [[0, 0, -1 if facing == "down" else 1]] * 4, dtype=np.float64)
    f = np.array([[1, 3, 2], [1, 4, 3]]) if facing == "down" else np.array([[1, 2, 3], [1, 3, 4]])
    return p, n, f


def gather_tol() -> float:
    """The error bound of a shifted lattice's estimate of the fraction of rays hitting a square: the
    integrand is the indicator of a region with a smooth boundary, whose discrepancy decays as R^(-3/4)
    (Schmidt 1975, Beck 1987); 2 R^(-3/4) = 3.9e-3 at R = 4096, below the 0.012..0.023 that 3 binomial
    standard deviations of independent rays would allow."""
    return 2.0 * R ** -0.75


@pytest.mark.parametrize("a, h", [(1.0, 1.0), (0.5, 2.0), (3.0, 1.0)])
def test_gather_row_is_the_form_factor_of_a_front_facing_square(a, h):
    p, n, f = point_under_square(a, h, "down")
    ray = tr.intersector(p, f, "test")
    g = tr.gather_matrix(ray, p, n, f, R, seed=2, eps=tr.epsilon(p))
    row = g[0].toarray()[0]
    want = point_to_square_form_factor(a, h)
    assert row[0] == 0.0 and abs(row.sum() - want) <= gather_tol()
    # the barycentric weights interpolate the hit points: all on the plane z = h, centred by symmetry
    assert row @ p[:, 2] == pytest.approx(h * row.sum(), rel=1e-12)
    assert np.abs(row @ p[:, :2]).max() <= 2 * a * gather_tol()
    # negative control: the uniform-hemisphere fraction (solid angle / 2 pi) is rejected by the same bound
    uniform = 4.0 * math.asin((a * a) / (a * a + h * h)) / (2.0 * math.pi)
    assert abs(row.sum() - uniform) > gather_tol()


def test_gather_of_a_back_face_is_zero():
    p, n, f = point_under_square(1.0, 1.0, "up")
    g = tr.gather_matrix(tr.intersector(p, f, "test"), p, n, f, R, seed=2, eps=tr.epsilon(p))
    assert g[0].sum() == 0.0
    # control: the same square facing the point gathers
    p, n, f = point_under_square(1.0, 1.0, "down")
    assert tr.gather_matrix(tr.intersector(p, f, "test"), p, n, f, R, seed=2, eps=tr.epsilon(p))[0].sum() > 0.5


def test_hemisphere_hits_do_not_depend_on_the_chunk():
    p, n, f = point_under_square(1.0, 1.0, "down")
    p = np.concatenate([p, p[:1] + [[0.2, 0.1, 0.0]], p[:1] + [[-0.3, 0.2, 0.0]]])
    n = np.concatenate([n, n[:1], n[:1]])
    ray = tr.intersector(p, f, "test")

    def hits(chunk: int, seed: int = 4) -> np.ndarray:
        return np.concatenate([h.triangles for h in tr.hemisphere_hits(ray, p, n, 64, seed, 1e-4, chunk)])

    assert np.array_equal(hits(1), hits(7)) and np.array_equal(hits(2), hits(3))
    assert not np.array_equal(hits(1), hits(1, seed=5))  # control: another seed, other rays


def test_epsilon_is_a_fraction_of_the_bounding_box_diagonal():
    box = np.array([[0, 0, 0], [3, 4, 12], [1, 1, 1]], dtype=np.float64)  # diagonal 13
    assert tr.epsilon(box) == pytest.approx(13 * tr.EPSILON_FRACTION, rel=1e-15)
    assert tr.epsilon(box[:1]) > 0.0  # a single point: a positive floor, never 0


def good_object() -> tr.TransferObject:
    p, n, f = point_under_square(1.0, 1.0, "down")
    return tr.TransferObject(p, 2.0 * n, f.astype(np.int32), (0.5, 0.5, 0.5))


@pytest.mark.parametrize("field, value, message", [
    ("positions", lambda o: np.where(np.arange(15).reshape(5, 3) == 4, np.nan, o.positions),
     "positions contain NaN or Inf"),
    ("normals", lambda o: np.where(np.arange(15).reshape(5, 3) == 7, np.inf, o.normals), "normals contain NaN"),
    ("normals", lambda o: np.where(np.arange(5)[:, None] == 2, 0.0, o.normals), "1 normals have zero length"),
    ("normals", lambda o: o.normals[:4], r"normals have shape \(4, 3\), positions \(5, 3\)"),
    ("indices", lambda o: o.indices + 1, r"triangle indices out of range \(0..4\)"),  # one past the end
    ("indices", lambda o: o.indices - 2, r"triangle indices out of range \(0..4\)"),  # negative
    ("indices", lambda o: o.indices.astype(np.float64), "indices must be .* integers"),
    ("positions", lambda o: np.zeros((0, 3)), "positions must be"),
    ("kd", lambda o: (0.5, 0.5), "kd must be 3 values"),
])
def test_check_object_names_the_object_and_the_fault(field, value, message):
    good = good_object()
    bad = tr.TransferObject(**{**vars(good), field: value(good)})
    with pytest.raises(ValueError, match=f"^thing 3: {message}"):
        tr.check_object("thing 3", bad)


def test_check_object_accepts_and_normalises_a_good_object():
    checked = tr.check_object("thing 0", good_object())  # control of the refusals above
    assert np.allclose(np.linalg.norm(checked.normals, axis=1), 1.0, rtol=0, atol=1e-15)
    assert checked.indices.dtype == np.int64 and checked.positions.dtype == np.float64


@pytest.mark.parametrize("bounces, shadowed, message", [(-1, True, "bounces must be >= 0"),
                                                         (2, False, "bounces = 2 needs shadowed")])
def test_check_bounces(bounces, shadowed, message):
    with pytest.raises(ValueError, match=f"^X {message}"):
        tr.check_bounces("X", bounces, shadowed)
    tr.check_bounces("X", 0, False)  # control: no bounces need nothing
    tr.check_bounces("X", 2, True)


def test_merge_shifts_each_objects_triangles_to_its_own_vertices():
    a, b = tr.check_object("a", good_object()), tr.check_object("b", good_object())
    b = tr.CheckedObject(b.positions + 10.0, b.normals, b.indices[::-1], b.kd)
    m = tr.merge([a, b])
    assert m.offsets.tolist() == [0, 5, 10]
    assert np.array_equal(m.positions[m.faces[:2]], a.positions[a.indices])
    assert np.array_equal(m.positions[m.faces[2:]], b.positions[b.indices])
    assert not np.array_equal(m.positions[m.faces[2:]], b.positions[a.indices])  # control: b's own order
