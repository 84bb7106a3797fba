"""The quadrature's glTF metallic-roughness shading (groundtruth/exact/quadrature.py, type "pbr") against
independent expectations: the white furnace against E(mu) at each pixel, a dielectric's albedo integrated in the
test from the spec's text, a near-mirror against env(r) F(n.v), a linear environment against the spec's f
integrated in the test, the nested grids' own sums against E, the back-face rule, and extreme inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

import scenes
from groundtruth.exact import gltf_brdf, quadrature, raycast
from scenes.environment import environments, envmap
from scenes.environment.directions import equirect_directions, normalize
from scenes.model.scene import Material
from tests.groundtruth.gltf_spec import hemisphere_grid, spec_f
from tests.helpers import sphere_scene_text, write_scene

CONSTANT = np.ones((8, 16, 3), dtype=np.float32)


def pbr(base=(1.0, 1.0, 1.0), metallic=1.0, roughness=0.5, two_sided=False) -> Material:
    return Material("pbr", base_color=tuple(base), metallic=metallic, roughness=roughness, two_sided=two_sided)


def points(mu: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(normals, views) at random orientations with n.v = mu."""
    rng = np.random.default_rng(seed)
    n = normalize(rng.normal(size=(len(mu), 3)))
    t = normalize(np.cross(n, rng.normal(size=(len(mu), 3))))
    return n, mu[:, None] * n + np.sqrt(1.0 - mu * mu)[:, None] * t


def furnace_pbr_scene(tmp_path, roughness: float, metallic: float = 1.0, size: int = 16) -> scenes.Scene:
    material = f'{{ type = "pbr", base_color = [1.0, 1.0, 1.0], metallic = {metallic}, roughness = {roughness} }}'
    text = sphere_scene_text("furnace-pbr", 'map = "builtin:constant"\nparams = { radiance = 1.0 }', material, size,
                             object_lines="resolution = 48", tables='[realtime]\nglossy = "split_sum"')
    return scenes.load(write_scene(tmp_path, text))


def expected_furnace(scene) -> tuple[np.ndarray, np.ndarray]:
    """(per-pixel mean over the 4 x 4 sub-pixel rays of E(n.v), 0 where n.v <= 0; pixels every ray of which hits)."""
    hits = raycast.cast(scene, subpixels=4)
    mu = np.sum(hits.normal * -hits.direction, axis=-1)
    e = np.where(hits.hit & (mu > 0), gltf_brdf.directional_albedo(np.clip(mu, 0, 1), scene.objects[0].material
                                                                   .roughness), 0.0)
    return e.mean(axis=2), hits.hit.all(axis=2)


SLOW = pytest.mark.slow  # the 4096-wide cell grids of a sharp lobe take seconds to build


@pytest.mark.parametrize("roughness", [pytest.param(0.0, marks=SLOW), pytest.param(0.1, marks=SLOW), 0.5, 1.0])
def test_white_metal_furnace_is_the_directional_albedo(tmp_path, roughness):
    """Radiance 1 everywhere, base_color 1, metallic 1 (f0 = 1): each pixel is E(mu) averaged over its sub-pixel
    rays, mu from the numpy ray cast, E from gltf_brdf's rule (itself checked against Monte Carlo and closed forms
    in test_gltf_brdf.py). The quadrature reproduces it to its tables' precision (1e-8)."""
    scene = furnace_pbr_scene(tmp_path, roughness)
    q = quadrature.render(scene)
    expected, inside = expected_furnace(scene)
    assert np.isfinite(q.rgb).all()
    np.testing.assert_allclose(q.rgb[inside], np.repeat(expected[inside][:, None], 3, 1), atol=2e-6)  # float32 image
    # what is checked is there to be seen (E of a sharp lobe departs from 1 only near the silhouette)
    assert np.ptp(expected[inside]) > (1e-5 if roughness < 0.5 else 0.05)


def test_control_furnace_rejects_the_separable_visibility(tmp_path, monkeypatch):
    """The same check, the tables built from the product G1 G1 (the pre-2.0.1 V): off by up to ~0.1 at roughness 1."""
    scene = furnace_pbr_scene(tmp_path, 1.0)
    expected, inside = expected_furnace(scene)

    def separable(nl, nv, alpha, *_):
        a2 = alpha * alpha
        nl, nv = np.abs(nl), np.abs(nv)
        return 1.0 / ((nl + np.sqrt(a2 + (1 - a2) * nl * nl)) * (nv + np.sqrt(a2 + (1 - a2) * nv * nv)))

    monkeypatch.setattr(gltf_brdf, "V_smith_ggx_correlated", separable)
    gltf_brdf._dfg_table.cache_clear()
    try:
        q = quadrature.render(scene)
    finally:
        gltf_brdf._dfg_table.cache_clear()
    assert np.abs(q.rgb[inside][:, 0] - expected[inside]).max() > 0.02


def spec_albedo(base, metallic, roughness, mu, radiance=None) -> np.ndarray:
    """int f (n.l) L dl of the spec's f (gltf_spec.py) on a fixed hemisphere grid (wide lobes only)."""
    d, w = hemisphere_grid(300, 600)
    n, v = np.array([0.0, 0.0, 1.0]), np.array([math.sqrt(1 - mu * mu), 0.0, mu])
    f = spec_f(base, metallic, roughness, n, v, d) * d[:, 2:3]
    lum = 1.0 if radiance is None else radiance(d)
    return np.sum(f * lum * w[:, None], axis=0)


@pytest.mark.parametrize(("base", "metallic", "roughness"), [((0.2, 0.5, 0.9), 0.0, 0.6), ((0.8, 0.4, 0.1), 0.3, 1.0)])
def test_dielectric_furnace_is_its_own_albedo(base, metallic, roughness):
    """Radiance 1: a (partly) dielectric surface returns f0 A + B + kd Lambert, here computed apart as the spec's f
    (n.l) summed on a 300 x 600 hemisphere grid (1e-6 for these wide lobes); the diffuse weight 1 - F(v.h) depends
    on l, so this is not kd / pi E(n) times a constant."""
    mu = np.array([0.95, 0.7, 0.4, 0.15])
    n, v = points(mu, 1)
    got = quadrature.shade(pbr(base, metallic, roughness), CONSTANT, n, v)
    expected = np.array([spec_albedo(base, metallic, roughness, m) for m in mu])
    np.testing.assert_allclose(got, expected, atol=2e-6)
    # the control: the diffuse weight as 1 - w(n.v), a constant per point (the paper's blend), is off by > 1e-3
    f0, kd = gltf_brdf.colour_weights(base, metallic)
    a, b = gltf_brdf.dfg(mu, roughness)
    blend = f0 * a[:, None] + b[:, None] + kd * (1 - (1 - mu) ** 5)[:, None]
    assert np.abs(blend - expected).max() > 1e-3


def smooth_env(fn, height: int = 256) -> np.ndarray:
    """An equirect map (H, 2H, 3) sampling fn(direction) at its pixel directions (scenes' convention)."""
    return fn(equirect_directions(height, 2 * height)).astype(np.float32)


def sky(d: np.ndarray) -> np.ndarray:
    return np.stack([1.0 + 0.5 * d[..., 1] + 0.2 * d[..., 0], 0.8 + 0.3 * d[..., 2] ** 2, 0.5 + 0.4 * d[..., 0]], -1)


@pytest.mark.slow
def test_near_mirror_metal_reflects_the_environment_times_fresnel():
    """Roughness 0 (alpha = PBR_MIN_ALPHA): the lobe (~0.004 rad) averages a smooth environment to its value at
    the mirror direction r, and the metal's Schlick F(v.h) to F(n.v) (v.h = n.v at h = n; E(mu >= 0.25) > 1 - 1e-5).
    Expected: envmap.lookup(env, r) * (b + (1 - b)(1 - n.v)^5), within 1e-3 (measured 1.5e-4)."""
    env = smooth_env(sky)
    mu = np.array([1.0, 0.8, 0.5, 0.3, 0.25])
    n, v = points(mu, 3)
    base = np.array([0.9, 0.6, 0.3])
    got = quadrature.shade(pbr(base, 1.0, 0.0), env, n, v)
    r = 2 * mu[:, None] * n - v
    fresnel = base + (1 - base) * ((1 - mu) ** 5)[:, None]
    expected = envmap.lookup(env, r) * fresnel
    np.testing.assert_allclose(got, expected, rtol=1e-3)
    # controls: without the Fresnel rise, or the view direction's radiance instead of r's
    assert np.abs(envmap.lookup(env, r) * base / expected - 1).max() > 0.05
    assert np.abs(envmap.lookup(env, v) * fresnel / expected - 1).max() > 0.05


@pytest.mark.parametrize(("base", "metallic", "roughness"), [((1.0, 1.0, 1.0), 1.0, 0.6), ((0.3, 0.6, 0.9), 0.5, 1.0),
                                                              ((0.9, 0.6, 0.3), 0.0, 0.7)])
def test_linear_environment_is_weighted_as_the_spec_brdf(base, metallic, roughness):
    """L(l) = 1 + 0.8 a.l: the result is int f (n.l) dl + 0.8 a.int f (n.l) l dl, the lobe's first moment,
    computed apart from the spec's text on the hemisphere grid; the bilinear map's departure from linear is
    below 1e-5 at 256 x 512. Within 1.5e-3 relative (measured <= 7.6e-4: the cells weigh each kernel at
    their centre)."""
    a = normalize(np.array([0.3, 0.8, -0.5]))
    env = smooth_env(lambda d: np.repeat((1.0 + 0.8 * d @ a)[..., None], 3, -1))
    mu = np.array([0.9, 0.6, 0.35])
    n, v = points(mu, 5)
    got = quadrature.shade(pbr(base, metallic, roughness), env, n, v)
    for i in range(len(mu)):
        # the test's frame: n = z, v in xz; a expressed in it
        ez = n[i]
        ex = normalize(v[i] - mu[i] * n[i])
        ey = np.cross(ez, ex)
        a_local = np.array([a @ ex, a @ ey, a @ ez])
        radiance = lambda d, a_local=a_local: (1.0 + 0.8 * d @ a_local)[:, None]  # noqa: E731
        expected = spec_albedo(base, metallic, roughness, mu[i], radiance)
        np.testing.assert_allclose(got[i], expected, rtol=1.5e-3)


def test_control_linear_environment_rejects_the_separable_visibility(monkeypatch):
    """The same check with the kernels' V the product G1 G1 (tables unchanged, so a constant stays exact): the
    lobe's shape changes and the first moment with it."""
    a = normalize(np.array([0.0, 0.0, 1.0]))
    env = smooth_env(lambda d: np.repeat((1.0 + 0.8 * d @ a)[..., None], 3, -1))
    mu = np.array([0.3])
    n = np.array([[0.0, 0.0, 1.0]])
    v = np.array([[math.sqrt(1 - 0.09), 0.0, 0.3]])
    expected = spec_albedo((1, 1, 1), 1.0, 1.0, 0.3, lambda d: (1.0 + 0.8 * d[:, 2])[:, None])
    kernels = gltf_brdf.kernels

    def separable_kernels(mu, nl, vl, alpha, sin2_h=None):
        k, w = kernels(mu, nl, vl, alpha, sin2_h)
        a2 = alpha * alpha
        nlp = np.maximum(nl, 0.0)
        corr = 0.5 / (mu * np.sqrt(a2 + (1 - a2) * nlp * nlp) + nlp * np.sqrt(a2 + (1 - a2) * mu * mu))
        sep = 1.0 / ((nlp + np.sqrt(a2 + (1 - a2) * nlp * nlp)) * (mu + np.sqrt(a2 + (1 - a2) * mu * mu)))
        return k * (sep / corr), w

    monkeypatch.setattr(gltf_brdf, "kernels", separable_kernels)
    got = quadrature.shade(pbr((1, 1, 1), 1.0, 1.0), env, n, v)
    assert abs(got[0, 0] / expected[0] - 1) > 3e-3
    assert len(mu) == 1


@pytest.mark.parametrize("roughness", [pytest.param(0.0, marks=SLOW), pytest.param(0.1, marks=SLOW), 0.5, 1.0])
def test_nested_grids_sum_the_lobe_once(roughness):
    """Before normalisation the quadrature's own sum of K over the core and the used cells of every grid is its
    estimate of E(mu): within 1% of gltf_brdf's rule (mu >= 0.2; measured <= 0.6%), so each direction is counted
    once. The control: every grid summing all its cells beyond its own disc (no parent test) counts the tail
    again and again."""
    mu = np.linspace(0.2, 1.0, 30)
    n, v = points(mu, 7)
    alpha = gltf_brdf.alpha_of(roughness)
    r = normalize(2 * mu[:, None] * n - v)
    e = gltf_brdf.directional_albedo(mu, roughness)
    acc = quadrature._ggx_sums(CONSTANT, n, v, r, mu, alpha)
    np.testing.assert_allclose(acc[:, :, 3].sum(axis=1), e, rtol=1e-2)
    if roughness == 0.5:  # the finest grid is 128 wide for alpha = 0.25 (mu >= 0.2 > alpha: no grazing refinement)
        twice = np.zeros_like(acc)
        for width in (128, 64, 32):
            quadrature._ggx_level(CONSTANT, width, n, v, r, mu, alpha, twice, finest=width == 128, coarsest=True,
                                  theta_core=0.0)
        assert np.abs(twice[:, :, 3].sum(axis=1) / e - 1).max() > 0.05


def test_back_faces_one_sided_black_two_sided_flipped():
    """n.v <= 0: one-sided reflects nothing; two-sided shades as if the normal were -n (the paper's rule)."""
    env = smooth_env(sky, 64)
    mu = np.array([0.9, 0.5, 0.2])
    n, v = points(mu, 9)
    front = quadrature.shade(pbr((0.5, 0.7, 0.2), 0.3, 0.4), env, n, v)
    assert np.all(front > 0)
    np.testing.assert_array_equal(quadrature.shade(pbr((0.5, 0.7, 0.2), 0.3, 0.4), env, -n, v), 0.0)
    np.testing.assert_allclose(quadrature.shade(pbr((0.5, 0.7, 0.2), 0.3, 0.4, two_sided=True), env, -n, v), front,
                               rtol=1e-12)


@pytest.mark.slow
def test_extremes_stay_finite():
    """Roughness 0 at grazing (n.v = 1e-12 ... 1), v = n exactly, base_color 0 and 1, a sun of 1e6 and a constant
    1e6: finite, non-negative; a black metal (f0 = 0) still reflects at grazing."""
    sun = environments.builtin("sky", {"sun": 1e6, "sun_radius_deg": 0.5})
    mu = np.array([1.0, 0.9, 0.3, 1e-2, 1e-4, 1e-6, 1e-9, 1e-12])
    n, v = points(mu, 11)
    n = np.vstack([n, [[0.0, 1.0, 0.0]]])
    v = np.vstack([v, [[0.0, 1.0, 0.0]]])
    for env in (sun, CONSTANT * np.float32(1e6)):
        for base, metallic in (((0, 0, 0), 1.0), ((1, 1, 1), 0.0), ((1, 1, 1), 1.0)):
            for roughness in (0.0, 1.0):
                got = quadrature.shade(pbr(base, metallic, roughness, two_sided=True), env, n, v)
                assert np.all(np.isfinite(got)) and np.all(got >= 0), (base, metallic, roughness)
    black = quadrature.shade(pbr((0, 0, 0), 1.0, 0.0), CONSTANT, n[4:5], v[4:5])
    assert black[0, 0] > 0.5
