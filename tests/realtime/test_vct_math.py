"""The numpy half of voxel cone tracing (realtime/techniques/vct/vct_math.py), by hand, without GL; and the
[realtime.vct] table's checks (scenes/model/scene.py)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import scenes
from experiments.runs import rows
from realtime.engine import technique
from realtime.techniques.vct import vct_math
from scenes.model import technique_registry
from scenes.model.scene import SceneError


@pytest.mark.parametrize("count", [4, 6, 9])
def test_cone_weights_cover_the_cosine_lobe(count):
    cones = vct_math.cone_set(count)
    assert len(cones.directions) == count == len(cones.weights)
    assert cones.weights.sum() == pytest.approx(math.pi, rel=1e-12)
    assert (cones.weights > 0).all()
    assert np.allclose(np.linalg.norm(cones.directions, axis=1), 1.0)
    # every cone's cap lies above the horizon: no cone reads directions behind the surface
    assert (np.arccos(cones.directions[:, 2]) + cones.half_angle < math.pi / 2).all()
    # the ring's cones are equal by symmetry
    assert np.allclose(cones.weights[1:], cones.weights[1], rtol=1e-12)


def sphere_points(m: int) -> np.ndarray:
    """m equal-area Fibonacci points on the sphere (z uniform in (-1, 1))."""
    i = np.arange(m) + 0.5
    z = 1.0 - 2.0 * i / m
    r = np.sqrt(1.0 - z * z)
    phi = i * math.pi * (3.0 - math.sqrt(5.0))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], -1)


def monomials(w: np.ndarray, order: int) -> np.ndarray:
    """The monomials x^a y^b z^c of degree a + b + c <= `order` at unit directions w (P, 3): restricted to the
    sphere they span exactly the spherical harmonics of order <= `order` (any basis of that space will do: the
    test compares two integrals of the same functions)."""
    x, y, z = w.T
    cols = [x ** a * y ** b * z ** (d - a - b) for d in range(order + 1) for a in range(d + 1)
            for b in range(d - a + 1)]
    return np.stack(cols, -1)


def irradiance(values: np.ndarray, points: np.ndarray) -> np.ndarray:
    """int over the upper hemisphere of `values` (P, F) times the cosine, from equal-area sphere points."""
    upper = points[:, 2] > 0
    return 4.0 * math.pi * (values[upper] * points[upper, 2:3]).sum(0) / len(points)


def cone_rule(cones: vct_math.ConeSet, values: np.ndarray, points: np.ndarray) -> np.ndarray:
    """sum_k w_k (the mean of `values` (P, F) over cone k's cap), the caps' means taken over the points that
    fall in them (the equal-area points make the mean uniform in solid angle)."""
    out = np.zeros(values.shape[1])
    for d, w in zip(cones.directions, cones.weights, strict=True):
        inside = points @ d >= math.cos(cones.half_angle)
        out += w * values[inside].mean(0)
    return out


def seed_cone_set(count: int) -> vct_math.ConeSet:
    """The seed's layout: the ring at 60 degrees, each cone weighted by the cosine integral of its Voronoi cell
    of the hemisphere (normalised to pi)."""
    d = vct_math.ring_directions(count, 0.5)
    pts = sphere_points(400_000)
    pts = pts[pts[:, 2] > 0]
    w = np.bincount(np.argmax(pts @ d.T, 1), weights=pts[:, 2], minlength=count)
    return vct_math.ConeSet(d, vct_math.half_angle_for(count), math.pi * w / w.sum())


@pytest.mark.parametrize("count", [4, 6, 9])
def test_cones_integrate_radiance_of_order_two_exactly(count):
    """The cone rule sum_k w_k mean_cap_k(L) against the irradiance int_H L cos, both by numerical quadrature
    over 400 000 equal-area points (no closed form of either), for every monomial of degree <= 2 in w (which
    span the spherical harmonics of order <= 2), in frames turned about the normal (the ring's azimuth must not
    matter): equal within 2e-4 pi (the point quadrature's own error is about 3e-5 pi). Controls: some monomial
    of degree 3 or 4 misses by over 1e-3 pi (the rule is exact to order 2, not beyond), and the seed's ring at
    60 degrees with Voronoi weights misses degree 1 (L = n . w) by over 10 %."""
    cones = vct_math.cone_set(count)
    pts = sphere_points(400_000)
    for turn in (0.0, 0.3, 1.1):
        c, s = math.cos(turn), math.sin(turn)
        frame = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        values = monomials(pts @ frame.T, 2)
        exact = irradiance(values, pts)
        rule = cone_rule(cones, values, pts)
        assert np.allclose(rule, exact, atol=2e-4 * math.pi), (turn, rule - exact)
    quartic = monomials(pts, 4)
    assert np.abs(cone_rule(cones, quartic, pts) - irradiance(quartic, pts)).max() > 1e-3 * math.pi
    if count == 6:
        linear = pts[:, 2:3]
        seed = cone_rule(seed_cone_set(6), linear, pts)[0] / irradiance(linear, pts)[0]
        assert seed < 0.9, seed


def test_apertures_shrink_with_count():
    a4, a6, a9 = (vct_math.cone_set(n).half_angle for n in (4, 6, 9))
    assert a4 > a6 > a9
    with pytest.raises(ValueError, match="4, 6, 9"):
        vct_math.cone_set(5)


def solid_angle(half_angle: float) -> float:
    """A cone's solid angle, by integrating sin(theta) dtheta dphi over [0, a] numerically (not the closed form)."""
    theta = np.linspace(0.0, half_angle, 20001)
    return 2.0 * math.pi * float(np.trapezoid(np.sin(theta), theta))


@pytest.mark.parametrize("count", [4, 6, 9])
def test_cone_solid_angles_sum_to_the_hemisphere(count):
    """n cones together span the hemisphere's 2 pi sr; control: the seed's 30-degree half-angle for six cones
    leaves 1.23 sr uncovered, beyond the same tolerance."""
    total = count * solid_angle(vct_math.cone_set(count).half_angle)
    assert total == pytest.approx(2.0 * math.pi, rel=1e-6)
    if count == 6:
        assert abs(6 * solid_angle(math.radians(30.0)) - 2.0 * math.pi) > 1.0


@pytest.mark.parametrize(("count", "degrees"), [(4, 41.4096221), (6, 33.5573097), (9, 27.2660444)])
def test_half_angle_for_by_hand(count: int, degrees: float):
    """Equal-area cones: 1 - cos a = 1 / n; by hand acos(3/4) = 41.4096, acos(5/6) = 33.5573, acos(8/9) =
    27.2660 degrees. Called directly (cone_set caches its result)."""
    assert math.degrees(vct_math.half_angle_for(count)) == pytest.approx(degrees, abs=1e-6)


def march(alpha_at, d: np.ndarray, length: float, voxel: float, step: float, rule) -> float:
    """Transmittance of a ray along d over [0, length], sampled every step * voxel, through opacities
    alpha_at(t) (3,) per axis, each sample's step combined by `rule`."""
    ds = step * voxel
    t, T = 0.5 * ds, 1.0
    while t < length:
        T *= rule(alpha_at(t), d, ds, voxel)
        t += ds
    return T


def old_rule(alphas, d, ds, voxel) -> float:
    """The rule before: each sample adds its direction-weighted opacity whole, whatever the step."""
    return 1.0 - float((np.asarray(d) ** 2) @ np.asarray(alphas))


def squared_cosine_rule(alphas, d, ds, voxel) -> float:
    """The rule before: optical depths weighted by d's squared cosines (a medium alike along every axis)."""
    tau = -np.log(1.0 - np.minimum(np.asarray(alphas, dtype=np.float64), vct_math.MAX_ALPHA))
    return math.exp(-float((np.asarray(d) ** 2) @ tau) * ds / voxel)


@pytest.mark.parametrize("alpha", [0.05, 0.3, 0.8])
@pytest.mark.parametrize("cos_n", [1.0, 0.6, 0.3])
def test_stacked_layers_pass_their_product_at_any_angle_and_step(alpha, cos_n):
    """Six layers of normal y, one a voxel, each covering alpha of a voxel's cross-section along y and
    nothing along x or z (a surface's coverage is transparent along its own plane): a ray crossing them at
    cos_n to their normal crosses each layer once, so T = (1 - alpha)^6 whatever the angle and the step
    (0.5, 0.25, 0.125 voxel). Controls: the squared-cosine rule gives (1 - alpha)^(6 cos_n) (a grazing ray
    slips through), and a sample adding its alpha whole depends on the step."""
    h = 0.1
    d = np.array([math.sqrt(1.0 - cos_n ** 2), cos_n, 0.0])
    path = 6 * h / cos_n
    want = (1.0 - alpha) ** 6
    layers = lambda t: np.array([0.0, alpha, 0.0])  # noqa: E731
    for step in (0.5, 0.25, 0.125):
        got = march(layers, d, path, h, step, vct_math.step_transmittance)
        assert got == pytest.approx(want, rel=1e-9), (step, got, want)
    if cos_n < 1.0:
        wrong = march(layers, d, path, h, 0.25, squared_cosine_rule)
        assert abs(math.log(wrong / want)) > 0.05 * abs(math.log(want)) + 0.01
    old = [march(layers, d, path, h, step, old_rule) for step in (0.5, 0.25)]
    assert abs(math.log(old[0] / old[1])) > 0.05 and abs(math.log(old[0] / want)) > 0.05


@pytest.mark.parametrize("cos_n", [1.0, 0.7, 0.3])
def test_an_opaque_layer_stops_oblique_rays(cos_n):
    """A one-texel opaque layer perpendicular to y (its +-y faces opaque, the x and z faces half opaque, as a
    mip level holding the layer in one of its two sub-layers reads): a ray crossing it at cos_n >= 0.3 to its
    normal passes at most 0.5 %. Control: the previous rule, the step-corrected weighted mean of opacities
    1 - (1 - sum_a d_a^2 alpha_a)^(ds / texel), passes (0.5 (1 - cos_n^2))^(1 / cos_n): 14 % at 0.7, 7 % at 0.3."""
    h = 0.1
    d = np.array([math.sqrt(1.0 - cos_n ** 2), cos_n, 0.0])
    path = h / cos_n

    def layer(t):
        return np.array([0.5, 1.0, 0.5])

    def mean_rule(a, dd, ds, v):
        return (1.0 - min(float((dd * dd) @ a), vct_math.MAX_ALPHA)) ** (ds / v)

    assert march(layer, d, path, h, 0.5, vct_math.step_transmittance) < 5e-3
    if cos_n < 1.0:
        assert march(layer, d, path, h, 0.5, mean_rule) > 0.05


def test_glossy_cone_follows_the_phong_lobe():
    # 2 pi (1 - cos a) = 2 pi / (N + 1)
    a = vct_math.glossy_half_angle(50.0)
    assert 2 * math.pi * (1 - math.cos(a)) == pytest.approx(2 * math.pi / 51)
    assert math.degrees(vct_math.glossy_half_angle(0.0)) == pytest.approx(30.0)  # clamped
    assert math.degrees(vct_math.glossy_half_angle(1e7)) == pytest.approx(1.0)  # clamped
    assert vct_math.glossy_half_angle(10.0) > vct_math.glossy_half_angle(100.0)


@pytest.mark.parametrize("cos_r", [1.0, 0.5, 0.19, 0.0, -0.3, -1.0])
def test_a_uniform_lobe_above_the_horizon_is_the_lune(cos_r):
    """N = 0 is the uniform hemisphere about r: the share above the surface is the lune between the two
    hemispheres, 1/2 + asin(n . r) / pi (exact at n . r = 0 and +-1; the midpoint rule's error elsewhere)."""
    expected = 0.5 + math.asin(cos_r) / math.pi
    assert vct_math.lobe_above_horizon(cos_r, 0.0) == pytest.approx(expected, abs=3e-3)


@pytest.mark.parametrize("exponent", [1.0, 10.0, 50.0, 1000.0])
def test_a_lobe_grazing_the_surface_is_half_above_and_one_along_n_is_whole(exponent):
    assert vct_math.lobe_above_horizon(0.0, exponent) == 0.5
    assert vct_math.lobe_above_horizon(1.0, exponent) == 1.0 and vct_math.lobe_above_horizon(-1.0, exponent) == 0.0


@pytest.mark.parametrize(("cos_r", "exponent"), [(0.19, 50.0), (0.05, 200.0), (0.4, 5.0), (-0.1, 50.0)])
def test_the_lobes_share_above_the_horizon_against_sampling_it(cos_r, exponent):
    """A second method: the lobe sampled as the reference's BSDF samples it (cos alpha = xi^(1/(N+1)), phi
    uniform), the share of samples with n . l > 0; 400k samples: standard error below 1e-3."""
    rng = np.random.default_rng(7)
    xi, phi = rng.random(400_000), rng.random(400_000) * 2.0 * math.pi
    ca = xi ** (1.0 / (exponent + 1.0))
    n_dot_l = cos_r * ca + math.sqrt(1.0 - cos_r * cos_r) * np.sqrt(1.0 - ca * ca) * np.cos(phi)
    assert vct_math.lobe_above_horizon(cos_r, exponent) == pytest.approx(float(np.mean(n_dot_l > 0.0)), abs=4e-3)


def test_tangent_frame_is_orthonormal_with_n_last():
    for n in ([0, 1, 0], [1, 0, 0], [0.3, -0.4, 0.866]):
        f = vct_math.tangent_frame(np.array(n, dtype=float))
        assert np.allclose(f @ f.T, np.eye(3), atol=1e-12)
        assert np.allclose(f[2], np.array(n) / np.linalg.norm(n))


def test_cascades_double_and_level_selection_follows_the_cone_diameter():
    g = vct_math.Cascades((0.0, 0.0, 0.0), 1.0, 32, 3)
    h = g.voxel_size
    assert h == pytest.approx(2.0 / 32)
    assert [g.half_extent_of(c) for c in range(3)] == [1.0, 2.0, 4.0]
    assert g.cascade_of(np.array([0.5, 0, 0])) == 0
    assert g.cascade_of(np.array([1.5, 0, 0])) == 1
    assert g.cascade_of(np.array([3.5, 0, 0])) == 2
    assert g.cascade_of(np.array([4.5, 0, 0])) == -1
    origin = np.zeros(3)
    assert g.level_of(origin, h) == (0, 0.0)
    assert g.level_of(origin, 2 * h) == (1, 0.0)  # cascade 1's voxels are 2 h
    assert g.level_of(origin, 4 * h) == (2, 0.0)
    c, mip = g.level_of(origin, 16 * h)  # beyond the cascades: the outermost one's mips
    assert (c, mip) == (2, pytest.approx(2.0))
    # a narrow cone outside the finest cascade: the finest cascade holding it, at its level 0
    assert g.level_of(np.array([1.5, 0, 0]), h) == (1, 0.0)
    one = vct_math.Cascades((0.0, 0.0, 0.0), 1.0, 32, 1)  # a plain 3D texture: its own mips
    assert one.level_of(origin, 4 * h) == (0, pytest.approx(2.0))


def test_level_selection_with_a_mip_floor_reads_no_cascade_at_level_0():
    """mip_min 1 (the injection's bounce passes, which rewrite every cascade's level 0): by hand on three
    cascades of 32^3 (h = 1/16): a 2 h cone at the centre reads cascade 0's mip 1 (texel 2 h, where mip_min 0
    reads cascade 1's level 0, also 2 h); 5 h: cascade 1, mip log2(5) - 1; 16 h: cascade 2, mip 2 either way
    (the seed's rule already reads a mip there); a 2 h cone at x = 1.5, held only by cascades 1 and 2, reads
    cascade 1's mip 1 (4 h: coarser than the cone, the finest texel there that is no level 0)."""
    g = vct_math.Cascades((0.0, 0.0, 0.0), 1.0, 32, 3)
    h, origin = g.voxel_size, np.zeros(3)
    assert g.level_of(origin, 2 * h, mip_min=1.0) == (0, 1.0)
    assert g.level_of(origin, 2 * h) == (1, 0.0)
    c, mip = g.level_of(origin, 5 * h, mip_min=1.0)
    assert (c, mip) == (1, pytest.approx(math.log2(5.0) - 1.0))
    assert g.level_of(origin, 16 * h, mip_min=1.0) == (2, pytest.approx(2.0))
    assert g.level_of(np.array([1.5, 0, 0]), 2 * h, mip_min=1.0) == (1, 1.0)
    assert g.level_of(np.array([1.5, 0, 0]), 2 * h) == (1, 0.0)  # control: the seed's rule reads its level 0


def test_cascaded_memory_against_one_texture_of_the_same_finest_voxel():
    g = vct_math.Cascades((0.0, 0.0, 0.0), 1.0, 64, 3)
    per = g.bytes_per_cascade(48)
    assert per == sum((64 >> m) ** 3 for m in range(7)) * 48
    single = g.single_texture_bytes(48)
    assert single == sum((256 >> m) ** 3 for m in range(9)) * 48
    assert 3 * per < single / 20  # three 64^3 cascades against one 256^3 texture
    lo, hi = np.array([-1.0, 0.0, -2.0]), np.array([1.0, 1.0, 2.0])
    c = vct_math.cascades_for(lo, hi, 32, 2, margin=1.0)
    assert c.centre == (0.0, 0.5, 0.0) and c.half_extent_of(1) == pytest.approx(2.0)


def test_anisotropic_mip_of_a_half_filled_voxel():
    # a 2x2x2 block whose +X half is opaque red, the -X half empty
    faces = np.zeros((6, 2, 2, 2, 4))
    faces[:, 1, :, :] = [1.0, 0.0, 0.0, 1.0]
    m = vct_math.anisotropic_mip(faces)[:, 0, 0, 0]
    # along X every pair holds one opaque child: opaque from +X and from -X
    assert m[0, 3] == pytest.approx(1.0) and m[1, 3] == pytest.approx(1.0)
    # along Y or Z half the pairs are empty: half opaque
    for f in (2, 3, 4, 5):
        assert m[f, 3] == pytest.approx(0.5)
    # directional colour: a +X face that is green on the filled children's -X side only
    faces[1, 1, :, :] = [0.0, 1.0, 0.0, 1.0]  # what the filled half emits toward -X
    m = vct_math.anisotropic_mip(faces)[:, 0, 0, 0]
    assert np.allclose(m[0], [1, 0, 0, 1]) and np.allclose(m[1], [0, 1, 0, 1])  # behind an empty half: seen as is
    # a cone travelling +X reads the -X face (what leaves toward it), one travelling -X the +X face
    assert np.allclose(vct_math.read_direction(m, np.array([1.0, 0, 0])), [0, 1, 0, 1])
    assert np.allclose(vct_math.read_direction(m, np.array([-1.0, 0, 0])), [1, 0, 0, 1])
    d = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    assert vct_math.read_direction(m, d)[3] == pytest.approx(0.75)


def test_front_to_back_inside_the_mip():
    # along X: a half-transparent blue child in front of an opaque red one, seen from +X
    faces = np.zeros((6, 2, 2, 2, 4))
    faces[:, 1] = [0.0, 0.0, 0.5, 0.5]  # premultiplied
    faces[:, 0] = [1.0, 0.0, 0.0, 1.0]
    m = vct_math.anisotropic_mip(faces)[:, 0, 0, 0]
    assert np.allclose(m[0], [0.5, 0.0, 0.5, 1.0])  # from +X: blue in front
    assert np.allclose(m[1], [1.0, 0.0, 0.0, 1.0])  # from -X: the opaque red hides the blue


def test_mip_radiance_leaves_out_a_surfaces_back_columns(monkeypatch):
    # a 2x2x2 block, opaque everywhere; seen from +X two of its four columns (y = 0) show a lit front (grey 0.5),
    # the other two (y = 1) a surface's back: black toward +X, lit toward -X (the injection lights a face only
    # where its surface faces it). The texel blocks the whole column (alpha 1) and a cone from +X can reach the
    # back columns only through the front ones, so it reads the fronts' radiance: rgb / alpha = 0.5 on +X.
    faces = np.zeros((6, 2, 2, 2, 4))
    faces[:, :, :, :, 3] = 1.0
    faces[0, :, 0, :, :3] = 0.5  # +X faces of the y = 0 columns: lit
    faces[1, :, 1, :, :3] = 0.8  # -X faces of the y = 1 columns: lit the other way (their +X faces: backs)
    m = vct_math.anisotropic_mip(faces)[:, 0, 0, 0]
    assert m[0, 3] == pytest.approx(1.0)
    assert m[0, :3] == pytest.approx([0.5] * 3)
    # seen from -X the lit y = 1 columns are fronts and the y = 0 columns black there are backs (lit toward +X)
    assert m[1, :3] == pytest.approx([0.8] * 3)
    # a black column whose opposite face is black too is a dark surface, not a back: it stays in the mean
    dark = faces.copy()
    dark[1, :, 1, :, :3] = 0.0
    assert vct_math.anisotropic_mip(dark)[0, 0, 0, 0, 0] == pytest.approx(0.25)
    # negative control: the same function with no pair taken for a back (the plain mean) reads half the front
    monkeypatch.setattr(vct_math, "MIP_BACK_RATIO", -1.0)
    assert vct_math.anisotropic_mip(faces)[0, 0, 0, 0, 0] == pytest.approx(0.25)


def test_normal_mip_keeps_the_front_surfaces_normal():
    """A 2x2x2 block whose +X children (x = 1) hold an opaque surface of normal n1 and whose -X children (x = 0) a
    surface of normal n2, both facing +X (n_x > 0): seen from +X the front children hide the back ones, so the
    +X face's mipped normal is n1; with the front half transparent (alpha 1/2) it is the direction of
    n1 / 2 + n2 / 2 (the back's opacity 1 times the front's transmittance 1/2). The -X face holds the same two
    surfaces' other sides, normals mirrored in x (facing -X): its front is the x = 0 half, so it reads n2's
    mirror; that is also the negative control, the children composited in the other order."""
    n1 = np.array([0.8, 0.6, 0.0])
    n2 = np.array([0.6, 0.0, -0.8])
    mirror = np.array([-1.0, 1.0, 1.0])
    normals = np.zeros((6, 2, 2, 2, 3))
    normals[0, 1], normals[0, 0] = n1, n2
    normals[1, 1], normals[1, 0] = n1 * mirror, n2 * mirror
    alphas = np.ones((6, 2, 2, 2))
    m = vct_math.normal_mip(normals, alphas)[:, 0, 0, 0]
    assert m[0] == pytest.approx(n1)
    assert m[1] == pytest.approx(n2 * mirror)
    alphas[0, 1] = 0.5
    want = (n1 + n2) / np.linalg.norm(n1 + n2)
    assert vct_math.normal_mip(normals, alphas)[0, 0, 0, 0] == pytest.approx(want)


def test_normal_mip_is_zero_where_no_surface_faces_the_face():
    """No child holds a normal on the +Y face (the block's surfaces all face +X): the +Y face's mipped normal is 0,
    however opaque the children (opacity alone tells no direction); the +X face's is +X, the positive control."""
    normals = np.zeros((6, 2, 2, 2, 3))
    normals[0] = [1.0, 0.0, 0.0]
    m = vct_math.normal_mip(normals, np.ones((6, 2, 2, 2)))[:, 0, 0, 0]
    assert np.all(m[2] == 0.0)
    assert m[0] == pytest.approx([1.0, 0.0, 0.0])


def test_normal_mean_length_of_a_plane_is_one_whatever_its_opacities():
    """Every child holds the same normal: the mean of equal unit normals has length 1, however the faces'
    opacities weight them (a flat surface's texels must not read as spread)."""
    rng = np.random.default_rng(1)
    n = np.array([0.48, 0.6, 0.64])
    normals = np.broadcast_to(n, (6, 4, 4, 4, 3)).copy()
    got = vct_math.normal_mean_length_mip(normals, np.ones((6, 4, 4, 4)), rng.uniform(0.05, 1.0, (6, 4, 4, 4)))
    assert got == pytest.approx(np.ones((6, 2, 2, 2)))


def two_normals_side_by_side(theta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Unit normals n1, n2 theta apart about +y in two opaque children side by side in the +Y face's front layer
    (y = 1; x = 0 and 1), the other children empty: (n1, n2, normals, alphas) for `normal_mean_length_mip`."""
    n1 = np.array([math.sin(theta / 2), math.cos(theta / 2), 0.0])
    n2 = np.array([-math.sin(theta / 2), math.cos(theta / 2), 0.0])
    normals = np.zeros((6, 2, 2, 2, 3))
    normals[2, 0, 1, 0], normals[2, 1, 1, 0] = n1, n2
    alphas = np.zeros((6, 2, 2, 2))
    alphas[2, :, 1, 0] = 1.0
    return n1, n2, normals, alphas


def test_normal_mean_length_of_two_normals_side_by_side():
    """Two opaque children side by side across the +Y face's axis (both in front: y = 1) with unit normals n1, n2,
    the others empty: the mean's length is |n1 + n2| / 2 = cos(theta / 2) for normals theta apart; children
    whose own normals already spread (length 0.9) scale it by 0.9. Control: the same two one behind the other
    (x equal, y = 1 and 0) leave the front one alone, length 1."""
    theta = math.radians(50.0)
    n1, n2, normals, alphas = two_normals_side_by_side(theta)
    ones = np.ones((6, 2, 2, 2))
    assert vct_math.normal_mean_length_mip(normals, ones, alphas)[2, 0, 0, 0] == pytest.approx(math.cos(theta / 2))
    assert vct_math.normal_mean_length_mip(normals, 0.9 * ones, alphas)[2, 0, 0, 0] == pytest.approx(
        0.9 * math.cos(theta / 2))
    behind = np.zeros((6, 2, 2, 2, 3))
    behind[2, 0, 1, 0], behind[2, 0, 0, 0] = n1, n2
    stacked = np.zeros((6, 2, 2, 2))
    stacked[2, 0, :, 0] = 1.0
    assert vct_math.normal_mean_length_mip(behind, ones, stacked)[2, 0, 0, 0] == pytest.approx(1.0)


def test_normal_spread_is_the_mean_cosine_about_the_stored_normal():
    """Two opaque children side by side with unit normals n1, n2 theta apart, n1's own normals unspread (l = 1),
    n2's spread (l = 0.5): the stored normal is their bisector (`normal_mip` weights the directions alone), and
    the spread is the children's means (n1 + 0.5 n2) / 2 projected on it, 0.75 cos(theta / 2) = 0.375 for
    theta = 120 degrees; the mean's length, 0.433, is its cosine about another direction. Control: equal spreads
    give cos(theta / 2)."""
    theta = math.radians(120.0)
    n1, n2, normals, alphas = two_normals_side_by_side(theta)
    lengths = np.ones((6, 2, 2, 2))
    lengths[2, 1, 1, 0] = 0.5
    got = vct_math.normal_mean_length_mip(normals, lengths, alphas)[2, 0, 0, 0]
    assert got == pytest.approx(0.75 * math.cos(theta / 2))
    assert np.linalg.norm(n1 + 0.5 * n2) / 2 > got + 0.05
    assert vct_math.normal_mean_length_mip(normals, np.ones_like(lengths), alphas)[2, 0, 0, 0] == pytest.approx(
        math.cos(theta / 2))


def test_reflection_spread_of_normals_on_a_cone_rim():
    """Unit normals all theta from their mean (a cone's rim; mean length cos theta) turn a mirror seen straight on
    by 2 theta each: the mirrors' mean cosine about the mean's mirror is cos 2 theta = 2 cos^2 theta - 1, the
    bound the read takes; measured by reflecting v = the mean normal in 720 normals on the rim."""
    theta = math.radians(20.0)
    phi = np.linspace(0.0, 2.0 * math.pi, 720, endpoint=False)
    normals = np.stack([math.sin(theta) * np.cos(phi), math.sin(theta) * np.sin(phi),
                        np.full_like(phi, math.cos(theta))], -1)
    v = np.array([0.0, 0.0, 1.0])
    mirrors = 2.0 * (normals @ v)[:, None] * normals - v
    length = float(np.linalg.norm(normals.mean(0)))
    assert length == pytest.approx(math.cos(theta))
    assert (mirrors @ v).mean() == pytest.approx(vct_math.reflection_spread_mean_cos(length), abs=1e-9)
    assert vct_math.reflection_spread_mean_cos(1.0) == 1.0
    assert vct_math.reflection_spread_mean_cos(0.5) == 0.0  # clamped: the mirrors as likely behind as ahead


def test_a_phong_lobe_convolved_with_a_cap_has_the_broadened_exponents_mean_cosine():
    """A direction drawn from the normalised Phong lobe (N = 50) about r, then uniformly from a cap of 16 degrees
    about that, has mean cosine about r equal to the product of the two's, (N + 1) / (N + 2) (1 + cos a) / 2
    (Funk-Hecke), which the Phong lobe of exponent broadened_exponent(N, cap_mean_cos(tan a)) has as well.
    200 000 samples: within 5e-4. Control: the unbroadened exponent's mean cosine is 0.009 off."""
    rng = np.random.default_rng(11)
    count, n, a = 200_000, 50.0, math.radians(16.0)

    def about(axis, cos_t):
        phi = rng.uniform(0.0, 2.0 * math.pi, len(axis))
        helper = np.where(np.abs(axis[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
        t = np.cross(helper, axis)
        t /= np.linalg.norm(t, axis=-1, keepdims=True)
        b = np.cross(axis, t)
        sin_t = np.sqrt(1.0 - cos_t ** 2)
        return (sin_t * np.cos(phi))[:, None] * t + (sin_t * np.sin(phi))[:, None] * b + cos_t[:, None] * axis

    r = np.tile([0.0, 0.0, 1.0], (count, 1))
    lobe = about(r, rng.uniform(size=count) ** (1.0 / (n + 1.0)))
    both = about(lobe, 1.0 - rng.uniform(size=count) * (1.0 - math.cos(a)))
    measured = float(both[:, 2].mean())
    broadened = vct_math.broadened_exponent(n, vct_math.cap_mean_cos(math.tan(a)))
    assert vct_math.cap_mean_cos(math.tan(a)) == pytest.approx((1.0 + math.cos(a)) / 2.0)
    assert measured == pytest.approx((broadened + 1.0) / (broadened + 2.0), abs=5e-4)
    assert abs(measured - (n + 1.0) / (n + 2.0)) > 0.008
    assert vct_math.broadened_exponent(n, 1.0) == pytest.approx(n)
    assert vct_math.broadened_exponent(0.0, 0.9) == 0.0  # broader than the cosine lobe: N' = 0


def test_cap_visibility_and_surface_bound():
    assert vct_math.cap_visibility(0.5, 1.0) == pytest.approx(0.75)
    assert vct_math.surface_voxel_bound(1.0, 0.1) > 4 * math.pi / 0.01


def small(**ov):
    return scenes.load("builtin:sphere-on-plane").with_overrides(ov)


@pytest.mark.parametrize(("key", "value", "allowed"), [
    ("realtime.vct.resolution", 12, "power of two in [8, 256]"),
    ("realtime.vct.resolution", 512, "power of two in [8, 256]"),
    ("realtime.vct.cascades", 5, "[1, 4]"),
    ("realtime.vct.diffuse_cones", 5, "one of 4, 6, 9"),
    ("realtime.vct.diffuse_cones", 6.0, "one of 4, 6, 9"),
    ("realtime.vct.step", 0.0, "(0, 4]"),
    ("realtime.vct.bounces", 0, "[1, 4]"),
    ("realtime.vct.bounces", 1.5, "[1, 4]")])
def test_vct_table_values_are_checked_naming_the_key(key, value, allowed):
    with pytest.raises(SceneError) as err:
        small(**{"realtime.occlusion": "vct", key: value})
    assert key.split(".")[-1] in str(err.value) and allowed in str(err.value)


def test_bounces_enter_the_content_id_only_when_set():
    """`bounces` was added after result-row ids were pinned: at its default 1 a scene's content (and so every
    earlier row's id) is unchanged; set to 2 it is part of it (control: the two contents then differ)."""
    one = small(**{"realtime.occlusion": "vct"})
    two = small(**{"realtime.occlusion": "vct", "realtime.vct.bounces": 2})
    assert "bounces" not in one.content_dict()["realtime"]["vct"]
    assert two.content_dict()["realtime"]["vct"]["bounces"] == 2
    assert one.realtime.vct.bounces == 1


def test_vct_combinations_and_unused_table():
    with pytest.raises(SceneError) as err:
        small(**{"realtime.interreflection": "vct"})
    assert "realtime.interreflection" in str(err.value) and "realtime.occlusion" in str(err.value)
    with pytest.raises(SceneError, match="realtime.vct"):
        small(**{"realtime.vct.resolution": 32})  # nobody reads the table
    s = small(**{"realtime.occlusion": "vct", "realtime.vct.resolution": 32})
    assert s.realtime.vct.resolution == 32


def test_unsimulated_effects_of_vct_configurations():
    assert technique.unsimulated_effects(small(**{"realtime.occlusion": "vct"})) == ["interreflection"]
    both = small(**{"realtime.occlusion": "vct", "realtime.interreflection": "vct"})
    assert technique.unsimulated_effects(both) == []
    # a glossy object: the glossy cone reaches its lobe too
    torus = scenes.load("builtin:torus-phong").with_overrides({"realtime.occlusion": "vct",
                                                                 "realtime.interreflection": "vct"})
    assert technique.unsimulated_effects(torus) == []
    assert technique.owner_of("realtime.vct.cascades") == ("occlusion", "vct")


def lowest_read_point(p: np.ndarray, n: np.ndarray, s: float, grid_origin: np.ndarray) -> float:
    """Height along n (above the plane through the origin) of the lowest point of the 2 x 2 x 2 texels of
    edge s a trilinear lookup at p reads (the texels whose centres lie within one texel of p on each axis;
    texel k on an axis spans [g + k s, g + (k + 1) s]): found box by box, not from the cap's formula."""
    low = 0.0
    for a in range(3):
        k0 = math.floor((p[a] - grid_origin[a]) / s - 0.5)
        lo, hi = grid_origin[a] + k0 * s, grid_origin[a] + (k0 + 2) * s
        low += min(n[a] * lo, n[a] * hi)
    return low


NORMALS = {"axis": [0.0, 1.0, 0.0], "edge": [1.0, 1.0, 0.0], "diagonal": [1.0, -1.0, 1.0],
           "oblique": [0.3, 0.9, -0.2]}


@pytest.mark.parametrize("name", list(NORMALS))
def test_footprint_cap_keeps_the_lookup_off_the_surface_and_is_tight(name):
    """The capped level's lookup never reaches the voxels of the surface the cone leaves, and one level
    coarser would. Expected from the boxes themselves: the surface's conservative voxels (boxes of edge h0
    crossing the plane) reach at most h0 |n|_1 above it; the lowest point of the eight texels read at the
    coarser level (edge h0 2^lod for an integer lod) is found box by box for random points, heights and
    grid offsets (lowest_read_point). A cap one level too fine or too coarse (a 1.5 texel reach taken as 1,
    the |n|_1 of a tilted normal dropped, floor taken as round) fails one of the two checks."""
    h0 = 1.0
    n = np.array(NORMALS[name]) / np.linalg.norm(NORMALS[name])
    n1 = np.abs(n).sum()
    top = h0 * n1  # the surface's own voxels lie below this height
    rng = np.random.default_rng(7)
    tangent = vct_math.tangent_frame(n)[:2]
    reaches_at_next = 0
    for _ in range(400):
        height = rng.uniform(2.5 * n1, 80.0)  # where the cap is above level 0 (below it the offsets decide)
        p = height * n + tangent.T @ rng.uniform(-20.0, 20.0, 2)
        origin = rng.uniform(0.0, 64.0, 3)  # the grid's corner: levels share it, texels are 2^lod voxels
        lod = vct_math.footprint_cap(height, n, h0)
        assert lod == int(lod) and lod >= 0
        assert lowest_read_point(p, n, h0 * 2.0 ** lod, origin) >= top - 1e-9, (height, lod)
        reaches_at_next += lowest_read_point(p, n, h0 * 2.0 ** (lod + 1), origin) < top
    assert reaches_at_next > 100  # one level coarser reaches the surface for a good share of the points


def test_sample_lod_by_hand():
    """The level a sample reads, computed by hand (h0 = 1, an axis-aligned surface, 24 voxels below the
    sample, cap floor(log2((24 - 1) / 1.5)) = floor(log2 15.3) = 3): a cone diameter below one voxel reads
    level 0; 2.4 and 4.8 voxels read log2 of them; 16 voxels is capped at 3; lod_min raises the level read
    but not the footprint (the step)."""
    up = np.array([0.0, 1.0, 0.0])
    assert vct_math.footprint_cap(24.0, up, 1.0) == 3.0
    assert vct_math.sample_lod(4.0, 0.05, 24.0, up, 1.0) == (0.0, 1.0)
    lod, diam = vct_math.sample_lod(4.0, 0.3, 24.0, up, 1.0)
    assert lod == pytest.approx(math.log2(2.4)) and diam == pytest.approx(2.4)
    lod, diam = vct_math.sample_lod(4.0, 0.6, 24.0, up, 1.0)
    assert lod == pytest.approx(math.log2(4.8)) and diam == pytest.approx(4.8)
    assert vct_math.sample_lod(4.0, 2.0, 24.0, up, 1.0) == (3.0, 8.0)
    assert vct_math.sample_lod(4.0, 0.05, 24.0, up, 1.0, lod_min=1.0) == (1.0, 1.0)
    # the voxel size scales out: h0 = 0.25 with every length scaled alike reads the same level
    assert vct_math.sample_lod(1.0, 0.6, 6.0, up, 0.25) == (pytest.approx(math.log2(4.8)), pytest.approx(1.2))


def samples_to_leave(grid: vct_math.Cascades, origin: np.ndarray, d: np.ndarray, step: float) -> int:
    """The samples a cone capped at the finest voxel all the way (every step `step` h0, the shortest a cone
    takes) from `origin` along `d` takes before its sample leaves the outermost cascade, counted by stepping."""
    t, count = 0.0, 0
    while grid.cascade_of(origin + t * d) >= 0:
        count += 1
        t += step * grid.voxel_size
    return count + 1


@pytest.mark.parametrize("resolution,cascades,step", [(16, 1, 0.5), (16, 3, 0.5), (8, 4, 0.3), (32, 2, 1.5)])
def test_no_cone_takes_more_samples_than_the_loop_allows(resolution, cascades, step):
    """max_cone_samples bounds the samples of every cone, counted by stepping from 300 random points and
    directions and along the outermost cascade's diagonal (the grazing cone's worst case: every step at the
    finest voxel's): none takes more than the bound, and the longest takes over half of it (the bound is not
    loose). Control: with several cascades, the bound of one cascade of the finest voxel (a fixed bound
    that ignores the coarser cascades' extent) is exceeded along the diagonal."""
    rng = np.random.default_rng(7)
    grid = vct_math.Cascades((0.1, -0.2, 0.3), 1.0, resolution, cascades)
    bound = vct_math.max_cone_samples(resolution, cascades, step)
    he = grid.half_extent_of(cascades - 1)
    worst = 0
    for _ in range(300):
        origin = np.asarray(grid.centre) + rng.uniform(-he, he, 3) * 0.95
        d = rng.normal(size=3)
        worst = max(worst, samples_to_leave(grid, origin, d / np.linalg.norm(d), step))
    corner = np.asarray(grid.centre) - 0.999 * he * (1.0 - 1.0 / resolution)
    along_diagonal = samples_to_leave(grid, corner, np.ones(3) / math.sqrt(3.0), step)
    worst = max(worst, along_diagonal)
    assert worst <= bound
    assert worst > 0.5 * bound, (worst, bound)
    if cascades > 1:
        assert along_diagonal > vct_math.max_cone_samples(resolution, 1, step)


@pytest.mark.parametrize("count", [4, 6, 9])
def test_diffuse_cones_leaving_a_plane_read_the_capped_level(count):
    """What the docs state: every diffuse cone of 4, 6 or 9 is wider than the footprint cap allows anywhere
    along it when it leaves a plane (its 2 tan(half-angle) >= 0.9 against a cap of at most 2/3 of the
    height), so it reads the capped level, while a cone a fifth as wide keeps its own, finer one. The
    heights are those of vct_diffuse's cones: the origin 1.5 voxels along n, then t cos(polar) more."""
    from realtime.techniques.vct import vct

    cones = vct_math.cone_set(count)
    tan_half = math.tan(cones.half_angle)
    up = np.array([0.0, 0.0, 1.0])
    narrower_somewhere = False
    for d in cones.directions:
        for t in np.linspace(vct.START_OFFSET_VOXELS, 60.0, 40):
            height = vct.NORMAL_OFFSET_VOXELS + t * d[2]
            cap = vct_math.footprint_cap(height, up, 1.0)
            assert vct_math.sample_lod(t, tan_half, height, up, 1.0)[0] == cap
            narrow = vct_math.sample_lod(t, tan_half / 5.0, height, up, 1.0)[0]
            assert narrow <= cap
            narrower_somewhere |= narrow < cap
    assert narrower_somewhere


def test_level_selection_outside_the_cascades_and_beyond_the_coarsest_mip():
    """By hand for 3 cascades of 32^3 voxels (levels 32, 16, ..., 1: mips 0 to 5) about the origin, finest
    half extent 1: a point outside every cascade (4.5 > 4 (1 - 1/32)) has no level, (-1, 0.0), as
    cascade_of says -1; a cone 2^10 finest voxels wide (lod 10) reads the outermost cascade (2) at its
    coarsest mip, 5 (a single voxel), not the lod - cascade = 8 that no mip holds."""
    g = vct_math.Cascades((0.0, 0.0, 0.0), 1.0, 32, 3)
    h = g.voxel_size
    outside = np.array([4.5, 0.0, 0.0])
    assert g.cascade_of(outside) == -1
    assert g.level_of(outside, h) == (-1, 0.0)
    assert g.level_of(outside, 8 * h) == (-1, 0.0)
    assert g.levels == 6
    assert g.level_of(np.zeros(3), 2.0**10 * h) == (2, 5.0)


def test_the_vct_model_version_enters_only_the_ids_of_rows_that_run_vct(monkeypatch):
    """A corrected estimator must not reuse stored rows: VCT's model_version is part of its rows' ids (a bumped
    version gives another id) and of no other row's (the control: a scene without VCT keeps its id)."""
    with_vct = small(**{"realtime.occlusion": "vct"})
    without = small()
    before = (rows.content_id(with_vct), rows.content_id(without))
    chosen = technique_registry.chosen

    def bumped(rt):
        return [dataclasses.replace(d, model_version=d.model_version + 1) if d.name == "vct" else d
                for d in chosen(rt)]

    monkeypatch.setattr(technique_registry, "chosen", bumped)
    assert rows.content_id(with_vct) != before[0]
    assert rows.content_id(without) == before[1]
    assert rows.content_id(with_vct, reference_only=True) == rows.content_id(without, reference_only=True)


def test_sum_scale_by_hand():
    """The voxeliser's fixed-point scales: the default where T triangles adding `largest` * default each stay
    within 2^31 - 1, else the largest power of two that does: 32,768 triangles of exponent 4096 at 16 reach
    2^31 exactly (one too many), so 8; 40,000 at 4096: 2^31 / 1.64e8 = 13.1, so 8; 2^31 / 4096 triangles of
    albedo 1 at 4096: 4096 (the default holds at 2^19 - 1 triangles, 2^19 of them get 2048)."""
    assert vct_math.sum_scale(16.0, 32_767, 4096.0) == 16.0
    assert vct_math.sum_scale(16.0, 32_768, 4096.0) == 8.0
    assert vct_math.sum_scale(16.0, 40_000, 4096.0) == 8.0
    assert vct_math.sum_scale(4096.0, 2 ** 19 - 1, 1.0) == 4096.0
    assert vct_math.sum_scale(4096.0, 2 ** 19, 1.0) == 2048.0
    assert vct_math.sum_scale(16.0, 10 ** 9, 4096.0) == 2.0 ** -11  # below one step a unit: still no overflow
    assert 10 ** 9 * 4096.0 * vct_math.sum_scale(16.0, 10 ** 9, 4096.0) <= vct_math.INT32_MAX
    assert vct_math.sum_scale(16.0, 0, 4096.0) == 16.0
