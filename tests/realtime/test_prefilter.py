"""The Phong-prefiltered chain (realtime/techniques/prefiltered/prefilter.py) against exact texel sums and analytic
limits."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest
from numpy.polynomial import legendre

from groundtruth.exact.reflectance import phong_lobe
from realtime.engine.context import get_context
from realtime.engine.cube_seams import seam_residual, smooth_lobes
from realtime.engine.gpu import EnvironmentFilter
from realtime.techniques.prefiltered.prefilter import PhongPrefilter, phong_convolve_numpy, phong_samples
from scenes.environment import cubemap, environments

pytestmark = pytest.mark.gl

NO_FIS = -100.0  # an LOD bias that clamps every sample to level 0


def cube_from_faces(faces: np.ndarray) -> moderngl.TextureCube:
    """An rgba32f cube map with faces (6, s, s, 3) as level 0 and the driver's mip chain below it."""
    faces = np.asarray(faces, dtype=np.float64)
    rgba = np.concatenate([faces, np.ones(faces.shape[:3] + (1,))], axis=-1).astype("f4")
    cube = get_context().texture_cube(faces.shape[1:3][::-1], 4, rgba.tobytes(), dtype="f4")
    cube.build_mipmaps()
    cube.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    return cube


def prefiltered(cube: moderngl.TextureCube, exponent: float, samples: int, bias: float, level: int) -> np.ndarray:
    p = PhongPrefilter(get_context(), cube.size[0], exponent, samples, bias)
    p.run(cube, level)
    out = p.read_level(level)
    p.release()
    return out


# ------------------------------------------------------------------------------ numpy halves


@pytest.mark.parametrize("exponent", [0.0, 1.0, 100.0, 1e6])
def test_sample_set_follows_the_lobe(exponent):
    # E[1 - cos a] under (N + 1) cos^N a over the hemisphere is 1 / (N + 2); unit directions.
    s = phong_samples(exponent, 4096, 256)
    one_minus_cos = s[:, 2]
    length = np.sqrt(s[:, 0] ** 2 + s[:, 1] ** 2 + (1.0 - one_minus_cos) ** 2)
    np.testing.assert_allclose(length, 1.0, atol=1e-12)
    np.testing.assert_allclose(one_minus_cos.mean(), 1.0 / (exponent + 2.0), rtol=1e-3)
    assert np.all((one_minus_cos > 0) & (one_minus_cos <= 1.0)) and np.all(np.isfinite(s))


@pytest.mark.parametrize("exponent", [0.0, 1.0, 10.0, 100.0])
@pytest.mark.parametrize("base_size", [16, 256])
def test_sample_levels_are_the_footprint_of_the_normalised_lobe(exponent, base_size):
    """Each sample's FIS level is 0.5 log2(Omega_s / Omega_p) with Omega_s = 1 / (samples pdf) and
    Omega_p = 4 pi / (6 base^2) a base texel's solid angle (Krivanek & Colbert 2008); pdf = cos^N a / Z
    with the lobe's normalisation Z = int cos^N dw = 2 pi int_0^1 mu^N dmu found here by Gauss-Legendre
    quadrature (exact for these integer N), not from the (N + 1) / (2 pi) formula. A wrong normalisation
    ((N + 2) instead of (N + 1), no 2 pi), a texel solid angle without the 6 faces or a level without its
    half shift the levels by 0.1 or more at N = 0 (negative control below)."""
    samples = 64
    s = phong_samples(exponent, samples, base_size)
    x, w = legendre.leggauss(64)
    mu = 0.5 * (x + 1.0)
    z = 2.0 * np.pi * np.sum(0.5 * w * mu**exponent)
    cos_a = 1.0 - s[:, 2]
    pdf = cos_a**exponent / z
    omega_p = 4.0 * np.pi / (6.0 * base_size**2)
    expected = 0.5 * np.log2(1.0 / (samples * pdf) / omega_p)
    np.testing.assert_allclose(s[:, 3], expected, rtol=0, atol=1e-9)
    # negative control: the pdf normalised as (N + 2) / (2 pi) moves every level by 0.5 log2((N + 2) / (N + 1))
    shift = 0.5 * np.log2((exponent + 2.0) / (exponent + 1.0))
    assert shift > 1e-3 and np.abs(s[:, 3] - (expected - shift)).min() > 1e3 * 1e-9


def test_numpy_reference_is_the_normalised_lobe_sum():
    rng = np.random.default_rng(7)
    faces = rng.uniform(0.0, 3.0, size=(6, 8, 8, 3))
    w = cubemap.texel_directions(8).reshape(-1, 3)
    omega = np.tile(cubemap.texel_solid_angles(8).reshape(-1), 6)
    r = cubemap.texel_directions(4).reshape(-1, 3)[::7]
    for exponent in (0.0, 3.0, 50.0):
        k = phong_lobe(1.0 - r @ w.T, exponent) * omega
        expected = k @ faces.reshape(-1, 3) / k.sum(axis=1, keepdims=True)
        np.testing.assert_allclose(phong_convolve_numpy(faces, r, exponent), expected, rtol=1e-10)


def test_numpy_reference_of_a_lobe_narrower_than_a_texel_is_finite():
    faces = np.random.default_rng(8).uniform(1.0, 2.0, size=(6, 16, 16, 3))
    got = phong_convolve_numpy(faces, np.array([[0.3, 0.2, -0.9]]), 1e9)
    assert np.all(np.isfinite(got)) and 1.0 <= got.min() and got.max() <= 2.0


# ------------------------------------------------------------------------------ the GPU kernel


@pytest.mark.parametrize("bias", [NO_FIS, 0.0])
def test_constant_map_stays_constant_for_every_exponent(bias):
    cube = cube_from_faces(np.full((6, 32, 32, 3), 2.5))
    for exponent in (0.0, 1.0, 10.0, 1e4, 1e6):
        p = PhongPrefilter(get_context(), 32, exponent, 64, bias)
        p.run(cube, 0)
        for level in range(p.n_levels):
            np.testing.assert_allclose(p.read_level(level), 2.5, rtol=1e-5, err_msg=f"N={exponent} level={level}")
        p.release()
    cube.release()


@pytest.mark.parametrize("exponent", [1.0, 10.0, 100.0])
def test_gpu_is_the_texel_sum_within_the_monte_carlo_bound(uffizi_64, exponent):
    # FIS off: the mean of `samples` lobe samples of level 0 against the exact lobe-weighted texel
    # sum. A Monte Carlo estimate errs by ~sigma / sqrt(samples), sigma^2 the lobe-weighted
    # variance of L; k = 4 is conservative for a low-discrepancy set.
    cube, level0 = uffizi_64
    samples, level = 256, 2
    got = prefiltered(cube, exponent, samples, NO_FIS, level)
    rng = np.random.default_rng(11)
    idx = tuple(rng.integers(0, [6, 16, 16], size=(12, 3)).T)
    r = cubemap.texel_directions(16)[idx]
    w = cubemap.texel_directions(64).reshape(-1, 3)
    omega = np.tile(cubemap.texel_solid_angles(64).reshape(-1), 6)
    k = phong_lobe(0.5 * np.sum((r[:, None] - w[None]) ** 2, axis=-1), exponent) * omega
    k /= k.sum(axis=1, keepdims=True)
    L = level0.reshape(-1, 3).astype(np.float64)
    mean = k @ L
    sigma = np.sqrt(np.maximum(k @ L**2 - mean**2, 0.0))
    np.testing.assert_allclose(mean, phong_convolve_numpy(level0, r, exponent), rtol=1e-9)
    assert np.all(np.abs(got[idx] - mean) <= 4.0 * sigma / np.sqrt(samples))


def test_lobe_about_a_texel_wide_gives_the_source_value_to_second_order():
    # N = 1e4 at base 256: the lobe's rms angle sqrt(2 / (N + 2)) ~ 0.014 rad is ~2 base texels. For a
    # smooth map the convolution is f(r) + E[a^2] / 4 Lap f(r) + O(N^-2), E[a^2] = 2 / (N + 2).
    base, exponent, level = 256, 1e4, 3
    f_base, _ = smooth_lobes(cubemap.texel_directions(base))
    cube = cube_from_faces(f_base[..., None] * np.array([1.0, 0.7, 0.4]))
    got = prefiltered(cube, exponent, 256, 0.0, level)[..., 0]
    f, lap = smooth_lobes(cubemap.texel_directions(base >> level))
    second_order = lap / (2.0 * (exponent + 2.0))
    err = got - f
    assert np.abs(err).max() <= 2.0 * np.abs(second_order).max()
    assert np.abs(err - second_order).max() <= 0.5 * np.abs(second_order).max()
    cube.release()


@pytest.mark.parametrize(("name", "params"), [("checker", {"cells": 16}), ("sky", {"sun": 1e3, "sun_radius_deg": 3.0})])
@pytest.mark.parametrize("exponent", [10.0, 100.0])
def test_filtered_importance_sampling_beats_plain_sampling_at_16_samples(name, params, exponent):
    # FIS trades aliasing (16 point reads of a high-frequency map) for a little blur: the rms error
    # against the exact convolution falls by more than 2x (measured 2.8-13x here).
    f = EnvironmentFilter(get_context(), environments.builtin(name, params), 64)
    f.fill_base(0.0)
    f.build_chain()
    level = 3  # face 8: the sampling, and so FIS's LOD, depends on the base size, not on the level written
    exact = phong_convolve_numpy(f.read_level(0), cubemap.texel_directions(8).reshape(-1, 3), exponent)
    exact = exact.reshape(6, 8, 8, 3)

    def rms(x):
        return float(np.sqrt(np.mean((x - exact) ** 2)))

    plain = rms(prefiltered(f.cube, exponent, 16, NO_FIS, level))
    fis = rms(prefiltered(f.cube, exponent, 16, 0.0, level))
    print(f"{name} N={exponent}: rms error, 16 samples: plain {plain:.4g}, FIS {fis:.4g}")
    assert fis < 0.5 * plain
    f.release()


def test_no_seams_at_blurry_levels():
    # Each texel is the convolution at its own centre, so on a smooth map the change per radian
    # across a face edge matches the change inside a face at every level: the ratio is 1 within the
    # grid's own few % (measured 0.983-0.994 for faces 64 ... 4, where the 2x2 box chain of the same
    # map goes 1.001, 1.003, 1.010, 1.026, 1.084: its seams grow with blur), and at the blurry
    # levels it is the exact convolution's own ratio (measured within 0.003).
    base, exponent = 128, 10.0
    f_base, _ = smooth_lobes(cubemap.texel_directions(base))
    faces0 = np.repeat(f_base[..., None], 3, axis=-1)
    cube = cube_from_faces(faces0)
    p = PhongPrefilter(get_context(), base, exponent, 64, 0.0)
    p.run(cube, 1)
    for level in range(1, 6):  # faces 64 ... 4
        faces = p.read_level(level)
        assert np.all(np.isfinite(faces))
        ratio = seam_residual(faces)["ratio"]
        assert abs(ratio - 1.0) < 0.05, level
        if level >= 4:
            s = base >> level
            exact = phong_convolve_numpy(faces0, cubemap.texel_directions(s).reshape(-1, 3), exponent)
            assert abs(ratio - seam_residual(exact.reshape(6, s, s, 3))["ratio"]) < 0.01, level
    p.release()
    cube.release()


@pytest.mark.parametrize("exponent", [0.0, 1e6])
def test_extreme_exponents_on_a_1e6_sun_write_finite_values(exponent):
    f = EnvironmentFilter(get_context(), environments.builtin("sky", {"sun": 1e6}), 64)
    f.fill_base(0.0)
    f.build_chain()
    for bias in (NO_FIS, 0.0):
        p = PhongPrefilter(get_context(), 64, exponent, 64, bias)
        p.run(f.cube, 0)
        for level in range(p.n_levels):
            faces = p.read_level(level)
            assert np.all(np.isfinite(faces)) and faces.min() >= 0.0, (bias, level)
        p.release()
    f.release()


def test_rejects_a_source_of_another_size(uffizi_64):
    cube, _ = uffizi_64
    p = PhongPrefilter(get_context(), 32, 10.0, 16)
    with pytest.raises(ValueError, match="face size 64"):
        p.run(cube, 0)
    with pytest.raises(ValueError, match="exponent"):
        p.set_lobe(-1.0, 16)
    p.release()
