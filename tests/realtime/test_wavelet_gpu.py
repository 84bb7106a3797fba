"""Wavelet PRT on the GPU (realtime/techniques/wavelet_prt/wavelet_gpu.py and its compute shaders) against numpy
and against expectations derived here: the Haar coefficients of the read-back cube level (haar.py's recursive
transform, a second method beside the shader's box-chain formula), the kept indices against haar.select and a
hand-derived tie case, the per-vertex sums against the numpy sum and the test's brute-force texel sum, and
renders under a constant environment (a furnace: E = L sum_t cos+ dOmega_t, known per normal). Controls:
selection without area weights, K = 1 in the furnace."""

from __future__ import annotations

import numpy as np
import pytest

import realtime
from realtime.engine.context import get_context
from realtime.engine.gpu import EnvironmentFilter
from realtime.techniques.wavelet_prt import haar
from realtime.techniques.wavelet_prt import wavelet_transfer as wt
from realtime.techniques.wavelet_prt.wavelet_gpu import WaveletLighting, WaveletObject
from scenes.environment import cubemap, environments

from .test_render import analytic_sphere, small
from .test_wavelet_transfer import brute_force, scene_objects

pytestmark = pytest.mark.gl
BASE = 64


@pytest.fixture(scope="module")
def studio():
    f = EnvironmentFilter(get_context(), environments.builtin("studio"), BASE)
    f.fill_base(20.0)
    f.build_chain()
    yield f
    f.release()


def run_lighting(env_filter, size: int, terms: int) -> WaveletLighting:
    lighting = WaveletLighting(get_context(), size, terms)
    lighting.run(env_filter.cube)
    return lighting


def level_of(size: int) -> int:
    return int(np.log2(BASE // size))


@pytest.mark.parametrize("size", [8, 16, 64])
def test_coefficients_are_the_haar_transform_of_the_level(studio, size):
    lighting = run_lighting(studio, size, 1)
    coeffs, keys = lighting.read_coefficients()
    lighting.release()
    want = wt.lighting_coefficients(studio.read_level(level_of(size)))
    scale = np.abs(want).max()
    np.testing.assert_allclose(coeffs, want, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(keys, haar.selection_keys(want.reshape(6, size, size, 3)), rtol=0, atol=1e-6 * scale)
    # control: the coefficients of a mirrored face are told apart
    mirrored = wt.lighting_coefficients(np.ascontiguousarray(studio.read_level(level_of(size))[:, :, ::-1]))
    assert np.abs(coeffs - mirrored).max() > 1e-3 * scale


@pytest.mark.parametrize(("size", "terms"), [(8, 1), (8, 384), (16, 16), (16, 256), (64, 1024)])
def test_the_kept_coefficients_are_the_k_largest_area_weighted(studio, size, terms):
    lighting = run_lighting(studio, size, terms)
    coeffs, keys = lighting.read_coefficients()
    kept, values, dense = lighting.read_kept()
    lighting.release()
    assert list(kept) == list(haar.select(keys, terms))  # exactly, on the GPU's own keys
    np.testing.assert_array_equal(values, coeffs[kept])
    expect_dense = np.zeros_like(coeffs)
    expect_dense[kept] = coeffs[kept]
    np.testing.assert_array_equal(dense, expect_dense)
    # against numpy's keys (argsort of area-weighted magnitudes): the same set but for near ties at the K-th key
    np_keys = haar.selection_keys(wt.lighting_coefficients(studio.read_level(level_of(size))).reshape(
        6, size, size, 3))
    differ = np.setxor1d(kept, haar.select(np_keys, terms))
    tau = np.sort(np_keys)[::-1][terms - 1]
    assert np.all(np.abs(np_keys[differ] - tau) <= 1e-5 * tau)
    if terms <= 16:  # control: the raw magnitudes (no area weight) choose other coefficients (at K = 256 the
        # studio's brightest coefficients are the same either way)
        raw = np.abs(coeffs).sum(axis=1)
        assert set(haar.select(raw, terms)) != set(kept)


def test_ties_go_to_the_smaller_index():
    """A constant environment: each face's scaling coefficient s L (key 3 s L), every detail exactly 0 (key 0).
    K = 10 keeps the six scaling coefficients (indices f s^2) and the four zero keys of smallest index, 1..4."""
    size = 8
    f = EnvironmentFilter(get_context(), np.full((32, 64, 3), 0.5, dtype=np.float32), 32)
    f.fill_base(0.0)
    f.build_chain()
    lighting = run_lighting(f, size, 10)
    kept, values, dense = lighting.read_kept()
    lighting.release()
    f.release()
    assert list(kept) == [0, 1, 2, 3, 4, *(face * size * size for face in range(1, 6))]
    np.testing.assert_allclose(values[[0, 5, 6, 7, 8, 9]], 0.5 * size, rtol=1e-6)
    assert (values[1:5] == 0).all()


@pytest.fixture(scope="module")
def sphere_on_plane_gpu(studio):
    scene, objects = scene_objects("builtin:sphere-on-plane", 8)
    transfers = wt.transfer(objects, 8, 0.0, 1, 0, shadowed=True)
    level = studio.read_level(level_of(8))
    return objects, transfers, level, brute_force(objects, level, shadowed=True)


@pytest.mark.parametrize("terms", [16, 128, 384])
def test_per_vertex_sums_equal_numpy(studio, sphere_on_plane_gpu, terms):
    objects, transfers, level, brute = sphere_on_plane_gpu
    lighting = run_lighting(studio, 8, terms)
    kept, values, dense = lighting.read_kept()
    for i, t in enumerate(transfers):
        obj = WaveletObject(get_context(), t, f"object {i}")
        obj.run(lighting)
        got = obj.read()
        obj.release()
        want = wt.irradiance(t, dense)
        # float32 products summed in float32 over the K kept: a few ulps of sum |w| |l| per vertex
        bound = 1e-5 * wt.irradiance(wt.SparseTransfer(t.offsets, t.indices, np.abs(t.values)), np.abs(dense))
        assert (np.abs(got - want) <= bound + 1e-30).all()
        if terms == 384:  # all terms: the brute-force texel sum of the test's own ray caster
            full = brute[i]
            assert np.abs(got - full).max() <= 1e-4 * np.abs(full).max()
            # control: the same sums with a transposed level are far from it
            transposed = wt.irradiance(t, wt.lighting_coefficients(np.ascontiguousarray(level.transpose(0, 2, 1, 3))))
            assert np.abs(transposed - full).max() > 1e-2 * np.abs(full).max()
    lighting.release()


def furnace_range(scene, size: int) -> tuple[float, float]:
    """min and max over the sphere's vertex normals of sum_t cos+ dOmega_t / pi (the furnace's E / (pi L))."""
    n = scene.objects[0].mesh.normals.astype(np.float64)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    dirs = cubemap.texel_directions(size).reshape(-1, 3)
    omega = np.tile(cubemap.texel_solid_angles(size).reshape(-1), 6)
    e = (np.maximum(n @ dirs.T, 0.0) * omega).sum(axis=1) / np.pi
    return float(e.min()), float(e.max())


@pytest.mark.parametrize("terms", [6, 1536, 1])
def test_furnace_render(tmp_path, monkeypatch, terms):
    """A constant environment L: each face has one non-zero coefficient, so K = 6 is already exact, and every
    pixel of the diffuse sphere is kd L x a value between the min and max over the vertex normals of
    sum_t cos+ dOmega_t / pi (the interpolation stays between its vertices). Control: K = 1 keeps one face."""
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))
    scene = small("builtin:sphere-diffuse", **{
        "realtime.diffuse": "wavelet_prt", "realtime.wavelet_prt.cube_size": 16, "realtime.wavelet_prt.terms": terms,
        "realtime.wavelet_prt.threshold": 0.0, "objects.*.resolution": 16, "objects.0.material.kd": [0.8, 0.5, 0.2],
        "environment.map": "builtin:constant", "environment.scale": 2.0})
    r = realtime.render(scene)
    lo, hi = furnace_range(scene, 16)
    interior = analytic_sphere(scene)[2] & r.mask  # 2 pixels from the silhouette (its back faces are black)
    ratio = r.rgb[interior] / (2.0 * np.array([0.8, 0.5, 0.2]))
    inside = (ratio >= lo * (1 - 1e-5)) & (ratio <= hi * (1 + 1e-5))
    assert inside.all() == (terms != 1)
    info = r.meta["wavelet_prt"]
    assert info["terms"] == terms and info["bytes_per_vertex"] > 0 and r.timings["filter"] > 0


@pytest.mark.parametrize("terms", [6144, 16])
def test_render_reads_each_vertex_own_irradiance(tmp_path, monkeypatch, terms):
    """The shading pass reads vertex v's sum by gl_VertexID: against PRT of order 8 (a separate technique whose
    per-vertex E is SH irradiance) under a sky with a broad sun off every axis (30 degrees of radius, azimuth 70,
    elevation 15, turned 40: no face or mirror of the cube looks like another), both interpolated alike, all terms
    agree to the quadrature and SH truncation (median 1.8e-4, max 0.12 %: bounds 5e-4 and 1 %); a vertex read at
    another index, or a precompute whose texel directions swap or mirror a face (tried by hand: median 3-18 %),
    would be off by the sky's gradient. Control: K = 16 (a coarse lighting) is rejected by the same bounds."""
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))
    base = {"objects.*.resolution": 24, "environment.map": "builtin:sky", "environment.rotation_deg": 40.0,
            "environment.params": {"sun": 0.5, "sun_radius_deg": 30.0, "sun_elevation_deg": 15.0,
                                   "sun_azimuth_deg": 70.0}}
    prt = realtime.render(small("builtin:sphere-diffuse", **base, **{"realtime.diffuse": "prt",
                                                                       "realtime.prt.order": 8}))
    scene = small("builtin:sphere-diffuse", **base, **{"realtime.diffuse": "wavelet_prt",
                                                        "realtime.wavelet_prt.terms": terms,
                                                        "realtime.wavelet_prt.threshold": 0.0})
    w = realtime.render(scene)
    m = analytic_sphere(scene)[2] & w.mask & prt.mask
    rel = np.abs(w.rgb[m] / prt.rgb[m] - 1)
    assert (np.median(rel) < 5e-4 and rel.max() < 1e-2) == (terms == 6144)
