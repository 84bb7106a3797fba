"""The split sum's GPU kernels (realtime/techniques/split_sum/chain.py, lut.py) against their numpy mirrors,
an independent quadrature, exact texel sums and analytic limits."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest

from realtime.engine.context import get_context
from realtime.engine.gpu import EnvironmentFilter
from realtime.techniques.split_sum import dfg, mappings
from realtime.techniques.split_sum.chain import GGXChain
from realtime.techniques.split_sum.lut import DFGTable
from realtime.techniques.split_sum.reference import ggx_convolve_numpy, ggx_texel_weights
from scenes.environment import cubemap, environments
from tests.realtime.test_split_sum_tables import quadrature_ab

pytestmark = pytest.mark.gl

NO_FIS = -100.0  # an LOD bias that clamps every sample to the source's level 0


def cube_from_faces(faces: np.ndarray) -> moderngl.TextureCube:
    """An rgba32f cube with faces (6, s, s, 3) as level 0 and the driver's mip chain below it."""
    faces = np.asarray(faces, dtype=np.float64)
    rgba = np.concatenate([faces, np.ones(faces.shape[:3] + (1,))], axis=-1).astype("f4")
    cube = get_context().texture_cube(faces.shape[1:3][::-1], 4, rgba.tobytes(), dtype="f4")
    cube.build_mipmaps()
    cube.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    return cube


def gpu_table(size: int, samples: int, precision: str = "f32", kind: str = "height_correlated") -> np.ndarray:
    t = DFGTable(get_context(), size, samples, precision, kind)
    try:
        t.compute()
        return t.read()
    finally:
        t.release()


# ------------------------------------------------------------------------------ the DFG table


@pytest.mark.parametrize("precision", ["f32", "f16", "u8"])
def test_gpu_table_is_its_numpy_mirror_at_the_stored_precision(precision):
    """float32 sums of the same Hammersley samples: within 3e-5 of the float64 mirror; stored at f16 or
    u8 they are the mirror's value rounded to nearest (measured: all 512; one step apart is allowed for a
    value on a rounding boundary), and every stored value is one the format holds. Without the shader's
    own rounding Mesa llvmpipe's imageStore truncates to half floats: half the f16 texels then miss."""
    got = gpu_table(16, 64, precision)
    want = dfg.dfg_table(16, 64)
    if precision == "f32":
        np.testing.assert_allclose(got, want, atol=3e-5)
        return
    q = dfg.quantise(want, precision)
    step = 1.0 / 255.0 if precision == "u8" else np.spacing(np.abs(q).astype(np.float16)).astype(np.float64)
    assert np.all(np.abs(got - q) <= step * 1.0001 + 1e-12)
    assert np.mean(got == q) > 0.99
    held = np.round(got * 255.0) / 255.0 if precision == "u8" else got.astype(np.float16).astype(np.float64)
    np.testing.assert_array_equal(got, held)


@pytest.mark.parametrize("kind", ["height_correlated", "separable"])
def test_gpu_table_is_the_quadrature_at_texel_centres(kind):
    """Texel (i, j) of an 8^2 table of 1024 samples against the product-rule quadrature at
    n.v = (i + 0.5) / 8, roughness = (j + 0.5) / 8, for each Smith form; the other form's quadrature
    misses at the roughest, most grazing texel (the control: the comparison sees V)."""
    got = gpu_table(8, 1024, "f32", kind)
    for i, j in [(0, 7), (2, 2), (4, 6), (7, 0), (1, 4)]:
        a, b = quadrature_ab((i + 0.5) / 8, (j + 0.5) / 8, kind)
        assert abs(got[j, i, 0] - a) < 1e-2 and abs(got[j, i, 1] - b) < 1e-2, (i, j)
    other = "separable" if kind == "height_correlated" else "height_correlated"
    a, b = quadrature_ab(0.5 / 8, 7.5 / 8, other)
    assert abs(got[7, 0, 0] + got[7, 0, 1] - a - b) > 0.05


def test_gpu_table_tends_to_a_mirror_at_roughness_zero():
    """The first row (roughness 1 / 32, alpha clamped at 0.045^2): A + B within 2e-3 of 1 at every
    n.v >= 0.1; the last row (roughness 31 / 32) loses energy (A + B < 0.8 from n.v = 0.25 on: the
    quadrature's 0.56 at roughness 1, n.v = 0.3)."""
    got = gpu_table(16, 256)
    nv = (np.arange(16) + 0.5) / 16
    assert np.all(np.abs(got[0, nv >= 0.1].sum(axis=-1) - 1.0) < 2e-3)
    assert np.all(got[-1, nv >= 0.25].sum(axis=-1) < 0.8) and np.all(np.isfinite(got))


# ------------------------------------------------------------------------------ the prefiltered chain


def chain_of(levels, source, samples: int, bias: float, sampling: str = "importance") -> list[np.ndarray]:
    c = GGXChain(get_context(), levels, source.size[0], [samples] * len(levels), sampling, bias)
    try:
        c.run(source)
        return [c.read_level(k) for k in range(len(levels))]
    finally:
        c.release()


@pytest.mark.parametrize("sampling", ["importance", "vndf"])
@pytest.mark.parametrize("bias", [NO_FIS, 0.0, 1.0])
def test_a_constant_map_stays_constant_at_every_level(sampling, bias):
    cube = cube_from_faces(np.full((6, 32, 32, 3), 2.5))
    try:
        for mapping, min_size in (("linear", 4), ("threejs", 16), ("babylon", 1)):
            for k, level in enumerate(chain_of(mappings.chain_levels(mapping, 32, min_size), cube, 64, bias,
                                               sampling)):
                np.testing.assert_allclose(level, 2.5, rtol=1e-5, err_msg=f"{mapping} level {k}")
    finally:
        cube.release()


def bound(level0: np.ndarray, n: np.ndarray, roughness: float, samples: int):
    """(exact P(n), 4 sigma / sqrt(samples)): the lobe-weighted texel mean and the spread of the n.l-weighted
    ratio estimator sum L n.l / sum n.l under the sampling density D(h) / 4 over l (the texels' D dOmega)."""
    w = ggx_texel_weights(64, n, roughness).reshape(len(n), -1)  # D n.l dOmega, normalised
    d = cubemap.texel_directions(64).reshape(-1, 3)
    nl = n @ d.T
    p = np.where(nl > 1e-6, w / np.maximum(nl, 1e-6), 0.0)  # the sampling density's D dOmega above the horizon
    p /= p.sum(axis=1, keepdims=True)
    L = level0.reshape(-1, 3).astype(np.float64)
    mean = w @ L
    e_nl = np.sum(p * nl, axis=1)
    var = np.stack([np.sum(p * nl ** 2 * (L[:, c][None, :] - mean[:, c:c + 1]) ** 2, axis=1) for c in range(3)], -1)
    return mean, 4.0 * np.sqrt(var) / e_nl[:, None] / np.sqrt(samples)


@pytest.mark.parametrize("roughness", [0.3, 0.6])
def test_gpu_level_is_the_exact_texel_sum_within_the_sampling_bound(uffizi_64, roughness):
    """FIS off: a 16-texel level of `roughness` from the 64-texel source against the exact n = v = r GGX
    texel sum of the source at 12 texels, within 4 sigma / sqrt(N) of the ratio estimator (measured: at most
    0.3 of the bound). The same check rejects the exact sum at another roughness (0.45 for 0.3, 0.8 for
    0.6: 5 and 1 of the 12 texels outside; the control)."""
    cube, level0 = uffizi_64
    samples = 256
    got = chain_of([mappings.Level(roughness, 16)], cube, samples, NO_FIS)[0]
    idx = tuple(np.random.default_rng(5).integers(0, [6, 16, 16], size=(12, 3)).T)
    n = cubemap.texel_directions(16)[idx]
    mean, tol = bound(level0, n, roughness, samples)
    np.testing.assert_allclose(mean, ggx_convolve_numpy(level0, n, roughness), rtol=1e-9)
    print(f"r={roughness}: |GPU - exact| / bound <= {np.max(np.abs(got[idx] - mean) / tol):.3f}")
    assert np.all(np.abs(got[idx] - mean) <= tol)
    wrong = ggx_convolve_numpy(level0, n, {0.3: 0.45, 0.6: 0.8}[roughness])
    assert not np.all(np.abs(got[idx] - wrong) <= tol)


def test_vndf_and_importance_chains_agree(uffizi_64):
    """256 samples: the two samplings draw one set of directions (test_split_sum_tables), so the levels agree
    to float32 rounding."""
    cube, _ = uffizi_64
    levels = mappings.chain_levels("linear", 32, 8)
    a = chain_of(levels, cube, 256, 0.0, "importance")
    b = chain_of(levels, cube, 256, 0.0, "vndf")
    for x, y in zip(a, b, strict=True):
        np.testing.assert_allclose(x, y, rtol=1e-4, atol=1e-6)


def test_a_1e6_sun_gives_finite_levels_at_roughness_zero_and_one():
    f = EnvironmentFilter(get_context(), environments.builtin("sky", {"sun": 1e6}), 32)
    f.fill_base(0.0)
    f.build_chain()
    try:
        for level in chain_of([mappings.Level(0.0, 32), mappings.Level(1.0, 8)], f.cube, 64, 0.0):
            assert np.all(np.isfinite(level)) and level.min() >= 0.0
    finally:
        f.release()


def test_rejects_a_source_of_another_size(uffizi_64):
    cube, _ = uffizi_64
    c = GGXChain(get_context(), [mappings.Level(0.5, 8)], 32, [16])
    with pytest.raises(ValueError, match="face size 64"):
        c.run(cube)
    c.release()
    with pytest.raises(ValueError, match="one count per level"):
        GGXChain(get_context(), [mappings.Level(0.5, 8)], 32, [16, 16])


@pytest.mark.parametrize(("name", "params"), [("checker", {"cells": 16}), ("sky", {"sun": 1e3, "sun_radius_deg": 3.0})])
@pytest.mark.parametrize("roughness", [0.3, 0.6])
def test_filtered_importance_sampling_beats_plain_sampling_at_16_samples(name, params, roughness):
    """16 samples a texel: reading each at the level of its footprint (FIS, bias 0) trades aliasing for a
    little blur; the rms error against the exact texel sum falls by more than 1.5x."""
    f = EnvironmentFilter(get_context(), environments.builtin(name, params), 64)
    f.fill_base(0.0)
    f.build_chain()
    try:
        exact = ggx_convolve_numpy(f.read_level(0), cubemap.texel_directions(8).reshape(-1, 3), roughness)
        exact = exact.reshape(6, 8, 8, 3)

        def rms(bias):
            got = chain_of([mappings.Level(roughness, 8)], f.cube, 16, bias)[0]
            return float(np.sqrt(np.mean((got - exact) ** 2)))

        plain, fis = rms(NO_FIS), rms(0.0)
        print(f"{name} r={roughness}: rms error at 16 samples: plain {plain:.4g}, FIS {fis:.4g}")
        assert fis < plain / 1.5
    finally:
        f.release()
