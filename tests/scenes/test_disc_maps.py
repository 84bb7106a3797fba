"""The 2D environment parameterizations' numpy halves: dual paraboloid and sphere map.

Independent expectations: round trips; the paraboloid's directions from the mirror reflection of its
axis about the surface f = 1/2 - r^2/2 (Heidrich & Seidel); the sphere map's (s, t) from OpenGL's
GL_SPHERE_MAP formula; exact texel solid angles against 4 pi, against a closed-form antiderivative
(the differential-area-to-rectangle view factor) and a Monte Carlo histogram of uniform directions;
the analytic max/min solid-angle ratios (cube 3 sqrt 3, dual paraboloid 4, sphere map 1); the stretch
(conformal vs equal-area); the capture frame against the camera's own view matrix, and an off-axis
capture frame (a 45 degree turn, written by hand) placing world directions at the mirror ball's positions.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from scenes.environment import cubemap, discmap, paraboloid, spheremap
from scenes.model.camera import Camera

MAPS = [paraboloid, spheremap]


def unit(rng, n: int) -> np.ndarray:
    d = rng.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("mod", MAPS, ids=lambda m: m.NAME)
def test_direction_position_direction_round_trip(mod, rng):
    d = unit(rng, 20000)
    d[:4] = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1e-9, -1]]  # axes and the sphere map's singular direction
    layer, x, y = mod.direction_to_position(d)
    assert np.all(x * x + y * y <= 1.0 + 1e-12)
    back = mod.position_to_direction(x, y, layer)
    np.testing.assert_allclose(back, d, atol=2e-8 if mod is spheremap else 1e-14)
    ok = np.abs(d[:, 2] + 1.0) > 1e-6  # away from the sphere map's singular rim (a whole circle there)
    np.testing.assert_allclose(back[ok], d[ok], atol=1e-12)


@pytest.mark.parametrize("mod", MAPS, ids=lambda m: m.NAME)
@pytest.mark.parametrize("size", [1, 2, 8, 64])
def test_texel_direction_texel_round_trip(mod, size):
    d = mod.texel_directions(size)
    assert d.shape == (mod.LAYERS, size, size, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-14)
    inside = mod.texel_solid_angles(size) > 0
    x, y = discmap.texel_positions(size)
    centre_in = np.broadcast_to(x * x + y * y < 1.0, inside.shape)
    layer, row, col = mod.direction_to_texel(d[centre_in], size)
    want_layer, want_row, want_col = np.nonzero(centre_in)
    np.testing.assert_array_equal(layer, want_layer)
    np.testing.assert_array_equal(row, want_row)
    np.testing.assert_array_equal(col, want_col)
    assert np.all(inside[centre_in])


def test_cube_direction_texel_round_trip():
    size = 16
    face, s, t = cubemap.direction_to_face(cubemap.texel_directions(size).reshape(-1, 3))
    f, j, i = np.unravel_index(np.arange(6 * size * size), (6, size, size))
    np.testing.assert_array_equal(face, f)
    np.testing.assert_allclose(s, (i + 0.5) / size, atol=1e-14)
    np.testing.assert_allclose(t, (j + 0.5) / size, atol=1e-14)


def test_paraboloid_directions_are_the_mirror_reflection_of_its_axis(rng):
    # f(x, y) = 1/2 - (x^2 + y^2) / 2 has normal (x, y, 1) / |.|; a ray along the axis (0, 0, -1) hitting it
    # leaves along reflect(-axis, n): that is the direction stored at (x, y) on the front map
    x, y = rng.uniform(-1.5, 1.5, size=(2, 5000))
    n = np.stack([x, y, np.ones_like(x)], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    incoming = np.array([0.0, 0.0, -1.0])
    reflected = incoming - 2.0 * (n @ incoming)[:, None] * n
    np.testing.assert_allclose(paraboloid.position_to_direction(x, y, 0), reflected, atol=1e-14)
    back = reflected * [1.0, 1.0, -1.0]
    np.testing.assert_allclose(paraboloid.position_to_direction(x, y, 1), back, atol=1e-14)


def test_sphere_map_is_opengl_sphere_map(rng):
    r = unit(rng, 5000)
    p = 2.0 * np.sqrt(r[:, 0] ** 2 + r[:, 1] ** 2 + (r[:, 2] + 1.0) ** 2)  # the GL spec's m = 2 p
    s_gl, t_gl = r[:, 0] / p + 0.5, r[:, 1] / p + 0.5
    _, x, y = spheremap.direction_to_position(r)
    s, t = discmap.position_to_texture(x, y)
    np.testing.assert_allclose(s, s_gl, atol=1e-15)
    np.testing.assert_allclose(t, t_gl, atol=1e-15)


@pytest.mark.parametrize("mod", [cubemap, *MAPS], ids=lambda m: getattr(m, "NAME", "cube"))
@pytest.mark.parametrize("size", [1, 2, 3, 16, 128])
def test_texel_solid_angles_sum_to_the_sphere(mod, size):
    w = mod.texel_solid_angles(size)
    total = 6 * w.sum() if mod is cubemap else w.sum()
    assert total == pytest.approx(4 * math.pi, rel=1e-12)
    assert np.all(w >= -1e-15)


@pytest.mark.parametrize("size", [4, 16, 33])
def test_paraboloid_inner_texels_match_the_view_factor_antiderivative(size):
    # integral of 4 / (1 + x^2 + y^2)^2 over [0, X] x [0, Y] = 2 [X/sqrt(1+X^2) atan(Y/sqrt(1+X^2)) + (X <-> Y)]
    # (the view factor from a differential area to a parallel rectangle at unit distance, times 2 pi)
    def anti(x, y):
        a, b = np.sqrt(1 + x * x), np.sqrt(1 + y * y)
        return 2.0 * (x / a * np.arctan(y / a) + y / b * np.arctan(x / b))

    e = np.linspace(-1.0, 1.0, size + 1)
    x0, y0 = np.meshgrid(e[:-1], e[:-1])
    x1, y1 = np.meshgrid(e[1:], e[1:])
    exact = anti(x1, y1) - anti(x0, y1) - anti(x1, y0) + anti(x0, y0)
    full = discmap.full_texels(size)
    assert full.sum() > 0
    np.testing.assert_allclose(paraboloid.texel_solid_angles(size)[0][full], exact[full], rtol=1e-12)
    np.testing.assert_allclose(spheremap.texel_solid_angles(size)[0][full], 4 * (2.0 / size) ** 2, rtol=1e-12)


@pytest.mark.parametrize("mod", MAPS, ids=lambda m: m.NAME)
def test_texel_solid_angles_match_a_monte_carlo_histogram(mod):
    # uniform directions binned by the forward mapping: each texel's share of 4 pi, within 4.5 sigma
    size, n = 8, 2_000_000
    rng = np.random.default_rng(7)
    layer, row, col = mod.direction_to_texel(unit(rng, n), size)
    counts = np.zeros((mod.LAYERS, size, size))
    np.add.at(counts, (layer, row, col), 1.0)
    w = mod.texel_solid_angles(size)
    estimate = counts * 4 * math.pi / n
    sigma = np.sqrt(w * (4 * math.pi - w) / n)
    assert np.all(np.abs(estimate - w) <= 4.5 * sigma + 1e-12)
    assert np.all(counts[w == 0] == 0)  # texels outside the disc receive no direction


def ratio(w: np.ndarray, full: np.ndarray) -> float:
    sel = np.broadcast_to(full, w.shape)
    return float(w[sel].max() / w[sel].min())


def test_solid_angle_ratios_tend_to_the_analytic_values():
    # cube: face centre / corner -> 3 sqrt 3; dual paraboloid: centre / rim -> 4; sphere map: equal area, 1
    sizes = (64, 256, 1024)
    cube = [ratio(cubemap.texel_solid_angles(s), np.ones((s, s), bool)) for s in sizes]
    para = [ratio(paraboloid.texel_solid_angles(s), discmap.full_texels(s)) for s in sizes]
    sphere = [ratio(spheremap.texel_solid_angles(s), discmap.full_texels(s)) for s in sizes]
    assert cube == sorted(cube) and para == sorted(para)
    assert cube[-1] == pytest.approx(3 * math.sqrt(3), rel=5e-3)
    assert para[-1] == pytest.approx(4.0, rel=5e-3)
    assert sphere == pytest.approx([1.0] * 3, abs=1e-9)


def test_paraboloid_is_conformal_and_the_sphere_map_equal_area(rng):
    rho = np.sqrt(rng.uniform(0, 0.98, 2000))
    phi = rng.uniform(0, 2 * math.pi, 2000)
    x, y = rho * np.cos(phi), rho * np.sin(phi)
    big, small = discmap.jacobian_singular_values(paraboloid.position_to_direction, x, y)
    np.testing.assert_allclose(big / small, 1.0, atol=1e-5)  # no stretch
    np.testing.assert_allclose(big * small, paraboloid.density(x, y), rtol=1e-5)
    np.testing.assert_allclose(big * small, 4.0 / (1.0 + rho**2) ** 2, rtol=1e-5)
    big, small = discmap.jacobian_singular_values(spheremap.position_to_direction, x, y, h=1e-7)
    np.testing.assert_allclose(big * small, 4.0, rtol=1e-4)  # equal area: dOmega / dA = 4
    np.testing.assert_allclose(big / small, 1.0 / (1.0 - rho**2), rtol=1e-3)
    # the stretch grows without bound at the rim
    b, s = discmap.jacobian_singular_values(spheremap.position_to_direction, np.array([0.9999]), np.array([0.0]),
                                            h=1e-9)
    assert b[0] / s[0] > 1000


@pytest.mark.parametrize("face", [1, 8, 16, 32, 64, 128, 256])
def test_budgets_round_to_the_nearest_power_of_two(face):
    for mod in MAPS:
        exact = face * math.sqrt(6 / mod.LAYERS)  # LAYERS m^2 = 6 s^2
        best = min((2**k for k in range(14)), key=lambda m: abs(math.log2(m) - math.log2(exact)))
        assert mod.map_size(face) == best
    assert paraboloid.texel_count(paraboloid.map_size(face)) == 8 * face * face
    assert spheremap.texel_count(spheremap.map_size(face)) == 4 * face * face


def test_capture_frame_is_the_cameras_eye_space():
    cam = Camera(origin=(1.0, 2.0, 3.0), target=(0.2, -0.1, 0.4), up=(0.0, 1.0, 0.0))
    frame = spheremap.capture_frame(np.subtract(cam.target, cam.origin), cam.up)
    np.testing.assert_allclose(frame, cam.view_matrix()[:3, :3], atol=1e-15)
    # the map's centre is the direction back at the viewer, its rim the direction straight ahead
    _, x, y = spheremap.direction_to_position(frame @ -np.subtract(cam.target, cam.origin))
    assert abs(x) < 1e-15 and abs(y) < 1e-15
    _, x, y = spheremap.direction_to_position(frame @ np.subtract(cam.target, cam.origin))
    assert math.hypot(x, y) == pytest.approx(1.0)
    # an up parallel to the view still gives a rotation
    f = spheremap.capture_frame([0.0, -1.0, 0.0], [0.0, 1.0, 0.0])
    np.testing.assert_allclose(f @ f.T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(f[2], [0.0, 1.0, 0.0], atol=1e-15)


def test_sphere_map_fill_is_continuous_across_the_rim():
    # just outside the disc, a texel holds the direction just past -z on the same great circle
    eps = 1e-6
    for phi in np.linspace(0, 2 * math.pi, 7):
        c, s = math.cos(phi), math.sin(phi)
        inside = spheremap.position_to_direction((1 - eps) * c, (1 - eps) * s)
        outside = spheremap.position_to_direction((1 + eps) * c, (1 + eps) * s)
        assert np.linalg.norm(inside - outside) < 1e-2
        assert outside[2] < -0.99


# A capture camera looking along (1, 0, -1) with up +y. By hand: right = forward x up = (1, 0, 1) / sqrt 2,
# true up = +y, back = -forward = (-1, 0, 1) / sqrt 2 (the rows of the world -> map rotation): a 45 degree
# turn about y, which differs from its transpose (the inverse turn), unlike the identity or an axis swap.
OFF_AXIS_FORWARD = (1.0, 0.0, -1.0)
OFF_AXIS_FRAME = np.array([[1.0, 0.0, 1.0], [0.0, math.sqrt(2.0), 0.0], [-1.0, 0.0, 1.0]]) / math.sqrt(2.0)
S225, S675 = math.sin(math.radians(22.5)), math.sin(math.radians(67.5))


def test_off_axis_capture_frame_by_hand():
    """capture_frame of a view along (1, 0, -1) is the hand-made 45 degree turn above; its transpose is not."""
    frame = spheremap.capture_frame(OFF_AXIS_FORWARD, (0.0, 1.0, 0.0))
    np.testing.assert_allclose(frame, OFF_AXIS_FRAME, atol=1e-15)
    assert np.abs(OFF_AXIS_FRAME - OFF_AXIS_FRAME.T).max() > 1.0  # the check can tell a transposed frame


@pytest.mark.parametrize(("world", "want", "transposed"), [
    ((1.0, 0.0, 0.0), (S675, 0.0), (S225, 0.0)),     # 135 degrees from the back axis, on the map's +x side
    ((0.0, 0.0, 1.0), (S225, 0.0), (-S225, 0.0)),    # 45 degrees from it
    ((-1.0, 0.0, 0.0), (-S225, 0.0), (-S675, 0.0)),
    ((0.0, 0.0, -1.0), (-S675, 0.0), (S675, 0.0)),
    ((0.0, 1.0, 0.0), (0.0, math.sqrt(0.5)), (0.0, math.sqrt(0.5))),  # the turn's axis: 90 degrees, rho sin 45
    ((-1.0, 0.0, 1.0), (0.0, 0.0), (-math.sqrt(0.5), 0.0)),  # back at the capture camera: the centre
])
def test_off_axis_capture_puts_world_directions_where_the_mirror_ball_says(world, want, transposed):
    """World direction -> map position through an off-axis capture frame, against the mirror ball by hand.

    A direction at angle theta from the map's +z (back at the capture camera) and azimuth phi in the
    map's xy plane sits at rho = sin(theta / 2) on that azimuth (the ball's normal halves the angle
    between the view and the reflection). The expected positions are those numbers for the hand-made
    frame above; `transposed` is where the inverse frame would put them (distinct except on the turn's
    axis). The round trip position -> direction -> world (rows: frame^T d) gives the direction back.
    """
    d = np.asarray(world) / np.linalg.norm(world)
    frame = spheremap.capture_frame(OFF_AXIS_FORWARD, (0.0, 1.0, 0.0))
    layer, x, y = spheremap.direction_to_position(frame @ d)
    assert layer == 0
    np.testing.assert_allclose([x, y], want, atol=1e-12)
    _, xt, yt = spheremap.direction_to_position(OFF_AXIS_FRAME.T @ d)  # the mistake: the inverse frame
    np.testing.assert_allclose([xt, yt], transposed, atol=1e-12)
    if world != (0.0, 1.0, 0.0):
        assert math.dist(want, transposed) > 0.5
    back = spheremap.position_to_direction(x, y) @ frame  # world direction: frame^T (map direction)
    np.testing.assert_allclose(back, d, atol=1e-12)
    # the same texel on a 64 x 64 map as the hand position gives (row from y, column from x)
    size = 64
    _, row, col = spheremap.direction_to_texel(frame @ d, size)
    hand = (min(int((want[1] + 1) / 2 * size), size - 1), min(int((want[0] + 1) / 2 * size), size - 1))
    assert (int(row), int(col)) == hand


# Points beyond the sphere map's disc (rho in (1, 2)) and, by hand, the direction each holds: the great
# circle through -z continued past it, i.e. the direction at rho' = 2 - rho on the opposite azimuth. A
# direction at angle theta from +z on azimuth phi sits at rho = sin(theta / 2); so (1.5, 0) holds the
# direction 2 asin(0.5) = 60 degrees from +z towards -x, (-sin 60, 0, cos 60).
BEYOND_THE_RIM = [
    ((1.5, 0.0), (-math.sqrt(3.0) / 2.0, 0.0, 0.5)),
    ((0.0, -1.9), (0.0, 2.0 * math.sqrt(0.99) * 0.1, 1.0 - 2.0 * 0.01)),  # rho' = 0.1 towards +y
    ((0.9, 1.2), (-2.0 * math.sqrt(0.75) * 0.3, -2.0 * math.sqrt(0.75) * 0.4, 0.5)),  # rho 1.5, rho' 0.5
    ((-1.2, 0.5), (2.0 * math.sqrt(1 - 0.49) * 0.7 * 12 / 13, -2.0 * math.sqrt(1 - 0.49) * 0.7 * 5 / 13,
                   1.0 - 2.0 * 0.49)),  # rho 1.3 on the azimuth (-12, 5) / 13, rho' 0.7 on (12, -5) / 13
]


@pytest.mark.parametrize(("position", "want"), BEYOND_THE_RIM)
def test_sphere_map_beyond_the_rim_holds_the_great_circle_past_minus_z(position, want):
    """A texel beyond the disc (which the box chain and bilinear lookups at the rim read) holds the direction
    on the same great circle past -z: rho' = 2 - rho on the opposite azimuth (module docstring). Expected
    values by hand from rho = sin(theta / 2). Negative controls: the direction without the continuation
    (every point beyond the rim clamped onto it: -z) and the one on the same azimuth are both far from it."""
    x, y = position
    d = spheremap.position_to_direction(x, y)
    np.testing.assert_allclose(d, want, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(want), 1.0, atol=1e-12)
    # on the great circle through +z, -z and the point's azimuth, past -z: on the far side of the axis
    assert abs(d[0] * y - d[1] * x) < 1e-12 and d[0] * x + d[1] * y < 0
    assert np.linalg.norm(d - [0.0, 0.0, -1.0]) > 0.5
    same_azimuth = np.array(want) * [-1.0, -1.0, 1.0]
    assert np.linalg.norm(d - same_azimuth) > 0.3


def test_sphere_map_centre_is_the_viewer_and_the_whole_rim_minus_z():
    """The map's landmarks (module docstring): its centre holds the direction back at the viewer, +z, and
    every point of the rim (rho = 1, here at 50 azimuths, where x^2 + y^2 may round just above 1) the
    single direction -z; finite, and with no floating-point warning (the centre is no division by 0)."""
    phi = np.linspace(0.0, 2.0 * math.pi, 50)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        centre = spheremap.position_to_direction(0.0, 0.0)
        rim = spheremap.position_to_direction(np.cos(phi), np.sin(phi))
    np.testing.assert_array_equal(centre, [0.0, 0.0, 1.0])
    assert np.all(np.isfinite(rim))
    np.testing.assert_allclose(rim, np.broadcast_to([0.0, 0.0, -1.0], rim.shape), atol=1e-7)


@pytest.mark.parametrize(("x_shape", "y_shape"), [((3,), ()), ((), (2, 3)), ((2, 1), (1, 3)), ((4,), (4,))])
def test_sphere_map_density_broadcasts_its_positions(x_shape, y_shape):
    """dOmega/dA of the sphere map is 4 at every plane position (equal area), one value per position of
    x and y broadcast together, as numpy broadcasts them (the dual paraboloid's density does the same)."""
    x, y = np.full(x_shape, 0.25), np.full(y_shape, -0.5)
    want = np.broadcast_shapes(x_shape, y_shape)
    got = spheremap.density(x, y)
    assert got.shape == want == paraboloid.density(x, y).shape
    np.testing.assert_array_equal(got, 4.0)


AXES = [(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)]


@pytest.mark.parametrize("forward", AXES)
@pytest.mark.parametrize("k", [1.0, -1.0, 3.0])
def test_capture_frame_with_up_parallel_to_forward_is_a_rotation(forward, k):
    """An up parallel to the view (along every axis, either sense, any length) is replaced by the world axis
    least aligned with the view: the frame is still a proper rotation whose back row is -forward and whose
    true up is a world axis perpendicular to it (the first such axis, x unless the view is along x)."""
    f = np.asarray(forward)
    frame = spheremap.capture_frame(f, k * f)
    np.testing.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(frame) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(frame[2], -f, atol=1e-15)
    want_up = np.eye(3)[1 if f[0] != 0 else 0]
    np.testing.assert_allclose(frame[1], want_up, atol=1e-15)


# a view along -z: an up turned by angle a from the view towards +y, (0, sin a, -cos a) (unnormalised below)
IDENTITY_FRAME = np.eye(3)  # up kept: right = forward x up = +x, true up +y, back +z
REPLACED_FRAME = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # up replaced by the x axis
TIE = 1.0000000000005e-06  # |forward x up| = 1e-6 |up| to the last bit for the up (0, TIE, -1)


@pytest.mark.parametrize("scale", [1.0, 0.01, 100.0])
def test_capture_frame_parallel_test_is_relative_to_up(scale):
    """Whether an up counts as parallel to the view (then replaced) depends on its angle to the view, not on
    its length: |forward x up| < 1e-6 |up|, strictly. By hand for a view along -z: an up 1e-5 rad off the
    view is kept at every length (the identity frame), one exactly along it is replaced (x axis up), and
    one exactly at the tolerance is kept (the comparison is strict); the two frames differ."""
    forward = np.array([0.0, 0.0, -1.0])
    assert np.linalg.norm(np.cross(forward, [0.0, TIE, -1.0])) == 1e-6 * np.linalg.norm([0.0, TIE, -1.0])
    kept = spheremap.capture_frame(forward, scale * np.array([0.0, math.sin(1e-5), -math.cos(1e-5)]))
    np.testing.assert_allclose(kept, IDENTITY_FRAME, atol=1e-12)
    replaced = spheremap.capture_frame(forward, scale * np.array([0.0, 0.0, -1.0]))
    np.testing.assert_allclose(replaced, REPLACED_FRAME, atol=1e-15)
    assert np.abs(IDENTITY_FRAME - REPLACED_FRAME).max() > 0.5
    if scale == 1.0:  # scaling the tie would round it off the boundary
        np.testing.assert_allclose(spheremap.capture_frame(forward, [0.0, TIE, -1.0]), IDENTITY_FRAME, atol=1e-12)
    # just inside the tolerance, every length of the same up gives the same frame
    near = np.array([0.0, 5e-7, -1.0])
    np.testing.assert_allclose(spheremap.capture_frame(forward, scale * near), REPLACED_FRAME, atol=1e-15)


def test_paraboloid_position_defaults_to_the_front_layer():
    """Without a layer, a plane position is on layer 0, the z >= 0 hemisphere: the centre is +z, (0.5, 0)
    is (2 x, 2 y, 1 - r^2) / (1 + r^2) = (0.8, 0, 0.6) by hand; layer 1 mirrors z."""
    np.testing.assert_allclose(paraboloid.position_to_direction(0.0, 0.0), [0.0, 0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(paraboloid.position_to_direction(0.5, 0.0), [0.8, 0.0, 0.6], atol=1e-15)
    np.testing.assert_allclose(paraboloid.position_to_direction(0.5, 0.0, 1), [0.8, 0.0, -0.6], atol=1e-15)


@pytest.mark.parametrize(("d", "layer"), [
    ((1.0, 0.0, 0.0), 0),     # on the equator (z = 0): layer 0, as for every z >= 0
    ((0.0, -1.0, 0.0), 0),
    ((1.0, 0.0, -0.0), 0),    # a negative zero is z >= 0 too
    ((1.0, 0.0, -1e-9), 1),   # just below it: layer 1
    ((0.0, 0.0, -1.0), 1),
])
def test_paraboloid_layer_boundary_is_the_equator_on_the_front(d, layer):
    """direction_to_position: layer 0 for z >= 0 (its docstring), so the equator belongs to the front layer;
    there the position is on the unit circle, (x, y) = (d_x, d_y) / (1 + |d_z|)."""
    got_layer, x, y = paraboloid.direction_to_position(np.array(d))
    assert int(got_layer) == layer
    np.testing.assert_allclose([x, y], np.array(d[:2]) / (1.0 + abs(d[2])), atol=1e-12)
