"""SH of orders 3 and 4 (numpy): basis, projection, clamped-cosine irradiance, deringing windows.

Every expectation is derived independently of the code under test: quadrature over the sphere,
SciPy's complex harmonics, the addition theorem with numpy's Legendre polynomials, 1-D integrals of
P_l, and the groundtruth quadrature's exact irradiance.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.polynomial import legendre

from realtime.engine import sh
from realtime.engine.sh_orders import irradiance_weights
from realtime.techniques.sh import deringing
from scenes.environment import cubemap, environments, envmap, shbasis
from scenes.environment.directions import equirect_directions, rotation_xyz
from scenes.environment.shbasis import COSINE_BAND_FACTORS, band_of, glsl_defines, sh9, sh_basis

PROBE_DIR = Path(__file__).resolve().parents[2] / "scenes" / "data" / "envs"
PROBES = ["uffizi", "ennis", "pisa", "wells"]
# The paper's bands 0-2 use 6-digit constants (0.282095 ...): relative rounding <= 1.4e-6 (0.315392 vs
# sqrt(5 / 16 pi) = 0.3153916), so quantities quadratic in them are off by up to ~3e-6.
PAPER_ROUNDING = 4e-6


def sphere_quadrature(n_theta: int = 24, n_phi: int = 48, z_range=(-1.0, 1.0)):
    """Directions (N, 3) and weights (N,): Gauss-Legendre in z = cos(theta) x uniform phi. Exact for
    polynomials in (x, y, z) of degree < min(2 n_theta, n_phi) on the band z_range."""
    t, wt = legendre.leggauss(n_theta)
    a, b = z_range
    z, wz = 0.5 * (b - a) * t + 0.5 * (b + a), 0.5 * (b - a) * wt
    phi = 2 * np.pi * np.arange(n_phi) / n_phi
    r = np.sqrt(1 - z * z)
    d = np.stack([np.outer(r, np.cos(phi)), np.outer(r, np.sin(phi)), np.repeat(z[:, None], n_phi, 1)], -1)
    return d.reshape(-1, 3), np.repeat(wz * 2 * np.pi / n_phi, n_phi)


def random_directions(n: int, seed: int = 0) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def cosine_factor(l: int) -> float:
    """A_l = 2 pi int_0^1 P_l(t) t dt (Funk-Hecke for max(cos, 0)), by Gauss-Legendre on [0, 1]."""
    t, w = legendre.leggauss(16)
    t, w = 0.5 * (t + 1), 0.5 * w
    return float(2 * np.pi * np.sum(w * legendre.legval(t, np.eye(l + 1)[l]) * t))


# --------------------------------------------------------------------------- the basis


def test_counts_and_bands():
    assert [shbasis.count(o) for o in range(5)] == [1, 4, 9, 16, 25]
    assert [shbasis.order_of(n) for n in (1, 4, 9, 16, 25)] == [0, 1, 2, 3, 4]
    np.testing.assert_array_equal(band_of(2), shbasis.BAND)
    np.testing.assert_array_equal(band_of(4), [0] + [1] * 3 + [2] * 5 + [3] * 7 + [4] * 9)
    with pytest.raises(ValueError):
        shbasis.order_of(10)


def test_order_2_is_sh9_bit_for_bit():
    d = random_directions(1000)
    assert np.array_equal(sh_basis(d, 2), sh9(d))
    assert np.array_equal(sh_basis(d, 4)[:, :9], sh9(d))
    assert np.array_equal(sh_basis(d, 4)[:, :16], sh_basis(d, 3))


def test_basis_is_orthonormal_up_to_order_4():
    # products are polynomials of degree <= 8: the quadrature is exact to rounding
    d, w = sphere_quadrature()
    y = sh_basis(d, 4)
    gram = np.einsum("nk,n,nj->kj", y, w, y)
    off = gram - np.diag(np.diag(gram))
    assert np.abs(off).max() < 1e-12
    # bands 3-4 carry full-precision constants: 1e-6 as asked, and in fact to rounding
    np.testing.assert_allclose(np.diag(gram)[9:], 1.0, atol=1e-12)
    np.testing.assert_allclose(np.diag(gram)[:9], 1.0, atol=PAPER_ROUNDING)


def test_convention_matches_scipy_without_condon_shortley_phase():
    # real SH from SciPy's complex Y_l^m (theta polar from +z, phi = atan2(y, x)); SciPy includes the
    # (-1)^m Condon-Shortley phase, which the project's basis (Y11 = +0.488603 x) does not:
    #   m > 0: sqrt2 (-1)^m Re Y_l^m,  m < 0: sqrt2 (-1)^m Im Y_l^|m|,  m = 0: Y_l^0
    from scipy.special import sph_harm_y

    d = random_directions(500, seed=3)
    theta, phi = np.arccos(d[:, 2]), np.arctan2(d[:, 1], d[:, 0]) % (2 * np.pi)
    ref = []
    for l in range(5):
        for m in range(-l, l + 1):
            c = sph_harm_y(l, abs(m), theta, phi)
            if m > 0:
                ref.append(math.sqrt(2) * (-1) ** m * c.real)
            elif m < 0:
                ref.append(math.sqrt(2) * (-1) ** m * c.imag)
            else:
                ref.append(c.real)
    ref = np.stack(ref, axis=-1)
    ours = sh_basis(d, 4)
    np.testing.assert_allclose(ours[:, :9], ref[:, :9], atol=PAPER_ROUNDING)
    np.testing.assert_allclose(ours[:, 9:], ref[:, 9:], atol=1e-12)


def test_glsl_defines_contract():
    defs = dict(s.split(" ", 1) for s in glsl_defines(4))
    assert defs["SH_ORDER"] == "4" and defs["SH_COUNT"] == "25"
    # bands 0-2: exactly the literals of sh_project.comp / docs/contract.md section 3
    assert [defs[f"SH_C{i}"] for i in range(5)] == ["0.282095", "0.488603", "1.092548", "0.315392", "0.546274"]
    # bands 3-4: the normalisation N_lm times P_l^(m)'s leading factor, to float32 precision
    n = lambda l, m: math.sqrt((2 * l + 1) / (4 * math.pi) * math.factorial(l - m) / math.factorial(l + m))  # noqa: E731
    expected = {"SH_K30": n(3, 0) / 2, "SH_K31": math.sqrt(2) * n(3, 1) * 1.5, "SH_K32": math.sqrt(2) * n(3, 2) * 15,
                "SH_K33": math.sqrt(2) * n(3, 3) * 15, "SH_K40": n(4, 0) / 8, "SH_K41": math.sqrt(2) * n(4, 1) * 2.5,
                "SH_K42": math.sqrt(2) * n(4, 2) * 7.5, "SH_K43": math.sqrt(2) * n(4, 3) * 105,
                "SH_K44": math.sqrt(2) * n(4, 4) * 105}
    for name, value in expected.items():
        assert float(defs[name]) == pytest.approx(value, rel=1e-8)
    # Sloan 2008 ("Stupid SH tricks", appendix) prints these to 6 digits
    assert float(defs["SH_K30"]) * 2 == pytest.approx(0.746353, abs=1e-6)  # Y30 = 0.746353 (5z^3 - 3z) / 2
    assert float(defs["SH_K44"]) == pytest.approx(0.625836, abs=1e-6)
    for l, a in enumerate([np.pi, 2 * np.pi / 3, np.pi / 4, 0.0, -np.pi / 24]):
        assert float(defs[f"SH_A{l}"]) == pytest.approx(a, rel=1e-8, abs=1e-12)
        assert "." in defs[f"SH_A{l}"] or "e" in defs[f"SH_A{l}"]  # a float literal in GLSL
    d2 = dict(s.split(" ", 1) for s in glsl_defines(2))
    assert d2["SH_COUNT"] == "9" and "SH_K30" not in d2 and "SH_A3" not in d2


# --------------------------------------------------------------------------- projection


@pytest.mark.parametrize("order", [3, 4])
def test_projecting_a_band_limited_cube_gives_its_coefficients(order, rng):
    # The exact texel solid angles make constants exact; what remains is the texel-centre (midpoint)
    # rule's O(h^2) error, h = 2 / size face units: with unit-variance coefficients it is ~4e-4 at
    # size 64 (bound 1e-3), and it must fall 4x from 32 to 64 (a convention error would not shrink).
    c = rng.normal(size=(shbasis.count(order), 3))
    err = {}
    for size in (32, 64):
        faces = sh_basis(cubemap.texel_directions(size), order) @ c
        err[size] = np.abs(sh.project_cube(faces, order) - c).max()
    assert err[64] < 1e-3
    assert 3.5 < err[32] / err[64] < 4.5


@pytest.mark.parametrize("order", [3, 4])
def test_projecting_a_band_limited_equirect_gives_its_coefficients(order, rng):
    # Mitsuba rows (align-corners) with exact band areas: again second order, ~1e-4 at 256 x 512
    c = rng.normal(size=(shbasis.count(order), 3))
    err = {}
    for h in (128, 256):
        env = sh_basis(equirect_directions(h, 2 * h), order) @ c
        err[h] = np.abs(sh.project_equirect(env, order=order) - c).max()
    assert err[256] < 5e-4
    assert 3.5 < err[128] / err[256] < 4.5


def test_order_2_projection_is_unchanged(rng):
    faces = rng.uniform(0, 2, size=(6, 16, 16, 3))
    assert np.array_equal(sh.project_cube(faces, 2), sh.project_cube(faces))
    np.testing.assert_allclose(sh.project_cube(faces, 4)[:9], sh.project_cube(faces), rtol=1e-12, atol=1e-14)
    env = environments.builtin("uffizi")
    assert np.array_equal(sh.project_equirect(env, 30.0, order=2), sh.project_equirect(env, 30.0))


def test_band_energy_of_order_4_is_rotation_invariant(rng):
    c = rng.normal(size=(25, 3))
    d = cubemap.texel_directions(64)
    e0 = sh.band_energy(sh.project_cube(sh_basis(d, 4) @ c, 4))
    assert e0.shape == (5, 3)
    for angles in ([30.0, 50.0, -20.0], [90.0, 0.0, 45.0]):
        R = rotation_xyz(angles)
        e1 = sh.band_energy(sh.project_cube(sh_basis(d @ R, 4) @ c, 4))  # the field turned by R
        np.testing.assert_allclose(e1, e0, rtol=2e-3, atol=1e-6)


# --------------------------------------------------------------------------- clamped-cosine irradiance


def test_cosine_band_factors_by_funk_hecke():
    # A_l = 2 pi int_0^1 P_l(t) t dt, and R&H 2001's closed forms
    ours = [cosine_factor(l) for l in range(5)]
    np.testing.assert_allclose(ours, [np.pi, 2 * np.pi / 3, np.pi / 4, 0.0, -np.pi / 24], atol=1e-14)
    np.testing.assert_allclose(COSINE_BAND_FACTORS[:5], ours, atol=1e-14)


def test_projection_of_the_clamped_cosine_is_zonal_with_the_band_factors():
    # f(w) = max(w.z, 0): f_l0 = int f Y_l0 = sqrt((2l + 1) / 4 pi) A_l and f_lm = 0 for m != 0.
    # The kink at z = 0 is a band edge of the quadrature, so it is exact on [0, 1].
    d, w = sphere_quadrature(z_range=(0.0, 1.0))
    f = np.einsum("nk,n,n->k", sh_basis(d, 4), w, d[:, 2])
    zonal = np.array([l * l + l for l in range(5)])
    np.testing.assert_allclose(np.delete(f, zonal), 0.0, atol=1e-12)
    a = np.sqrt(4 * np.pi / (2 * np.arange(5) + 1)) * f[zonal]
    np.testing.assert_allclose(a, [cosine_factor(l) for l in range(5)], rtol=PAPER_ROUNDING, atol=1e-12)


def band_limited_irradiance(lam, w0, normals, order):
    """sum_l A_l lam_l (2l + 1) / (4 pi) P_l(n.w0): the irradiance of a zonal field's band-limited
    projection by the addition theorem (sum_m Y_lm(a) Y_lm(b) = (2l + 1) / (4 pi) P_l(a.b))."""
    t = normals @ w0
    return sum(cosine_factor(l) * lam[l] * (2 * l + 1) / (4 * np.pi) * legendre.legval(t, np.eye(l + 1)[l])
               for l in range(order + 1))


@pytest.mark.parametrize("order", [2, 3, 4])
def test_directional_light_irradiance(order):
    # a delta of power P from w0: L_lm = P Y_lm(w0), i.e. a zonal field with lam_l = P
    w0 = np.array([0.3, 0.8, -0.52])
    w0 /= np.linalg.norm(w0)
    power = 5.0
    coeffs = power * sh_basis(w0, order)[:, None] * np.ones(3)
    n = random_directions(2000, seed=1)
    e = sh.irradiance_from_sh(coeffs, n)
    expected = band_limited_irradiance([power] * (order + 1), w0, n, order)
    np.testing.assert_allclose(e, np.repeat(expected[:, None], 3, 1), atol=PAPER_ROUNDING * power)


def test_order_4_approximates_a_directional_light_better():
    # Parseval: the squared error to P max(n.w0, 0) is the energy of the dropped bands; A_3 = 0, so
    # order 3 equals order 2 and order 4 removes band 4's share
    w0 = np.array([0.0, 0.6, 0.8])
    n, w = sphere_quadrature(n_theta=64, n_phi=128)
    exact = np.maximum(n @ w0, 0.0)
    err = {o: np.sum(w * (sh.irradiance_from_sh(sh_basis(w0, o)[:, None], n)[:, 0] - exact) ** 2)
           for o in (2, 3, 4)}
    assert err[3] == pytest.approx(err[2], rel=1e-10)
    band4 = 9 / (4 * np.pi) * cosine_factor(4) ** 2  # (2l + 1) / 4 pi A_l^2
    assert err[2] - err[4] == pytest.approx(band4, rel=1e-3)  # the quadrature sees the kink at n.w0 = 0


def test_narrow_lobe_on_a_cube():
    # a von Mises-Fisher lobe exp(k (w.w0 - 1)) of width ~1 / sqrt(k) = 9 degrees on 64^2 faces:
    # by Funk-Hecke its coefficients are lam_l Y_lm(w0), lam_l = 2 pi int_-1^1 f(t) P_l(t) dt
    kappa = 40.0
    w0 = np.array([0.48, -0.6, 0.64])
    w0 /= np.linalg.norm(w0)
    t, wt = legendre.leggauss(200)
    lam = [2 * np.pi * np.sum(wt * np.exp(kappa * (t - 1)) * legendre.legval(t, np.eye(l + 1)[l])) for l in range(5)]
    d = cubemap.texel_directions(64)
    faces = np.repeat(np.exp(kappa * (d @ w0 - 1))[..., None], 3, -1)
    coeffs = sh.project_cube(faces, 4)
    expected = np.array([lam[l] for l in band_of(4)]) * sh_basis(w0, 4)
    # texel-centre rule on a lobe ~17 texels wide: 1.4e-4 of the lobe's mass lam_0 (5.5e-4 at s = 32: O(h^2))
    np.testing.assert_allclose(coeffs[:, 0], expected, atol=5e-4 * lam[0])
    n = random_directions(500, seed=2)
    for order in (2, 4):
        e = sh.irradiance_from_sh(sh.project_cube(faces, order), n)[:, 0]
        np.testing.assert_allclose(e, band_limited_irradiance(lam, w0, n, order), atol=5e-4 * np.pi * lam[0])


def test_order_3_irradiance_equals_order_2(rng):
    faces = rng.lognormal(size=(6, 16, 16, 3))
    n = random_directions(1000, seed=4)
    e2 = sh.irradiance_from_sh(sh.project_cube(faces, 2), n)
    e3 = sh.irradiance_from_sh(sh.project_cube(faces, 3), n)
    np.testing.assert_allclose(e3, e2, rtol=1e-10, atol=1e-10 * np.abs(e2).max())


def test_constant_environment_gives_pi_at_every_order():
    # bands 1-3 of a constant vanish on any cube by its symmetry, but band 4 holds a cube-invariant
    # harmonic (x^4 + y^4 + z^4 - 3/5): its texel-quadrature residue, O(1/s^2), is ~1e-3 of pi at
    # s = 8 and ~1.5e-5 at s = 64
    faces = np.ones((6, 64, 64, 3))
    n = random_directions(100)
    for order, rtol in ((2, PAPER_ROUNDING), (3, PAPER_ROUNDING), (4, 5e-5)):
        np.testing.assert_allclose(sh.irradiance_from_sh(sh.project_cube(faces, order), n), np.pi, rtol=rtol)


@pytest.mark.parametrize("probe", PROBES)
def test_order_4_approximates_the_exact_irradiance_of_a_probe_better(probe):
    from groundtruth.exact import quadrature

    env = envmap.read(PROBE_DIR / f"{probe}.hdr")
    n = deringing.fibonacci_sphere(400)
    # quadrature.irradiance is E / pi (the cosine-weighted mean radiance); its own error is ~2e-4 of the peak
    exact = np.pi * quadrature.irradiance(quadrature.cell_grid(env, quadrature.DIFFUSE_WIDTH), n)
    rms = {}
    for order in (2, 3, 4):
        e = sh.irradiance_from_sh(sh.project_equirect(env, order=order), n)
        rms[order] = np.sqrt(np.mean((e - exact) ** 2) / np.mean(exact ** 2))
    assert rms[2] < 0.06  # R&H 2001: SH9 irradiance is within a few percent
    assert rms[3] == pytest.approx(rms[2], rel=1e-9)
    assert rms[4] < 0.5 * rms[2]


# --------------------------------------------------------------------------- weights and windows


def test_irradiance_weights_reconstruct_irradiance(rng):
    coeffs = rng.normal(size=(25, 3))
    sigma = np.array([1.0, 0.9, 0.7, 0.4, 0.2])
    w = irradiance_weights(coeffs, 4, sigma)
    n = random_directions(300)
    np.testing.assert_allclose(sh_basis(n, 4) @ w, sh.irradiance_from_sh(deringing.apply(coeffs, sigma), n),
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(w[9:16], 0.0)  # A_3 = 0
    with pytest.raises(ValueError):
        irradiance_weights(coeffs, 3)


def test_windows_of_every_order():
    x = np.arange(5) / 4.0
    np.testing.assert_allclose(deringing.window("hanning", 4.0, 4), [*(0.5 * (1 + np.cos(np.pi * x[:4]))), 0.0])
    np.testing.assert_allclose(deringing.window("lanczos", 4.0, 3), [1.0, *(np.sin(np.pi * x[1:4]) / (np.pi * x[1:4]))])
    assert np.array_equal(deringing.window("hanning", 2.5), deringing.window("hanning", 2.5, 4)[:3])
    coeffs = np.ones((16, 3))
    out = deringing.apply(coeffs, [1.0, 0.5, 0.25, 0.125])
    np.testing.assert_array_equal(out[:, 0], [1.0] + [0.5] * 3 + [0.25] * 5 + [0.125] * 7)
    with pytest.raises(ValueError):
        deringing.apply(coeffs, [1.0, 0.5, 0.25])


@pytest.mark.parametrize("order", [3, 4])
def test_auto_window_deringing_at_higher_orders(order):
    coeffs = sh.project_equirect(environments.builtin("sky", {"sun": 1e5}), order=order)
    choice = deringing.choose("auto", coeffs)
    assert len(choice.factors) == order + 1 and choice.min_before < 0
    e = sh.irradiance_from_sh(deringing.apply(coeffs, choice.factors), random_directions(200000, seed=7))
    assert e.min() >= -1e-3 * e.max()  # the Fibonacci grid minimum of a degree-4 polynomial
    weaker = deringing.apply(coeffs, deringing.window("hanning", choice.cutoff * 1.02, order))
    assert deringing.min_irradiance(weaker) < 0
    assert deringing.choose("none", coeffs).factors == (1.0,) * (order + 1)
    assert len(deringing.choose("lanczos", coeffs).factors) == order + 1
