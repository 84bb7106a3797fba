"""Hypothesis property tests: SH projection and reconstruction, tone mapping, Fresnel."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from groundtruth.exact import reflectance
from realtime.engine import sh
from scenes.environment.directions import equirect_directions
from scenes.environment.shbasis import sh9
from scenes.model import tonemap

finite = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
coeff_sets = arrays(np.float64, (9, 3), elements=finite)


def unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 1e-6, v / np.maximum(n, 1e-12), [0.0, 1.0, 0.0])


@settings(max_examples=60, deadline=None)
@given(coeffs=coeff_sets)
def test_projection_recovers_a_band_limited_map(coeffs):
    """Sample sum_k c_k Y_k on a map, project it back: the same coefficients (the basis is orthonormal)."""
    d = equirect_directions(128, 256)
    env = (sh9(d) @ coeffs).astype(np.float32)
    back = sh.project_equirect(env)
    scale = max(1.0, float(np.abs(coeffs).max()))
    np.testing.assert_allclose(back, coeffs, atol=2e-3 * scale)


@settings(max_examples=100, deadline=None)
@given(coeffs=coeff_sets, normals=arrays(np.float64, (16, 3), elements=finite))
def test_matrix_form_equals_the_sh_sum(coeffs, normals):
    """n^T M n (eq. 12, the shader's form) equals sum_lm A_l L_lm Y_lm(n) for any coefficients."""
    n = unit(normals)
    direct = sh.irradiance_from_sh(coeffs, n)
    matrix = sh.irradiance(sh.irradiance_matrices(coeffs), n)
    np.testing.assert_allclose(matrix, direct, atol=1e-4 * max(1.0, float(np.abs(coeffs).max())))


radiance = st.floats(0, 1e30, allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(rgb=arrays(np.float64, (8, 3), elements=radiance), key=st.floats(0.01, 1.0), white=st.floats(0.1, 1e3),
       exposure=st.floats(-10, 10), lum=st.floats(1e-6, 1e6))
def test_tonemap_is_finite_bounded_and_monotone(rgb, key, white, exposure, lum):
    out = tonemap.tonemap(rgb, key, white, exposure, lum)
    assert np.isfinite(out).all() and out.min() >= 0.0 and out.max() <= 1.0
    brighter = tonemap.tonemap(rgb * 2.0 + 1e-3, key, white, exposure, lum)
    assert (brighter >= out - 1e-7).all()


@settings(max_examples=200, deadline=None)
@given(f0=st.floats(0, 1), c=st.floats(-2, 2, allow_nan=False), dc=st.floats(0, 1))
def test_fresnel_bounded_monotone_and_exact_at_the_ends(f0, c, dc):
    f = float(reflectance.schlick(f0, np.array(c)))
    assert min(f0, 1.0) - 1e-12 <= f <= 1.0 + 1e-12
    assert float(reflectance.schlick(f0, np.array(min(c + dc, 2.0)))) <= f + 1e-12  # falls as n.v grows
    assert float(reflectance.schlick(f0, np.array(1.0))) == f0
    assert float(reflectance.schlick(f0, np.array(0.0))) == 1.0
