"""scenes.environment.shbasis bands 5..8 (PRT up to order 8): orthonormality by a quadrature written here,
an independent construction from scipy's associated Legendre functions, rotation invariance of each band's
energy, and the clamped-cosine factors against a numerical integral of P_l. Each check has a negative control."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.polynomial import legendre
from scipy.spatial.transform import Rotation
from scipy.special import factorial, lpmv

from scenes.environment import shbasis

ORDER = 8


def quadrature(n_theta: int = 12, n_phi: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre in z = cos(theta) x uniform phi: exact for polynomials of degree <= 2 n_theta - 1 in z and
    trigonometric polynomials of degree < n_phi in phi, so for products of two bands <= 8 (degree 16)."""
    z, wz = legendre.leggauss(n_theta)
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    zz, pp = np.repeat(z, n_phi), np.tile(phi, n_theta)
    r = np.sqrt(1 - zz * zz)
    d = np.stack([r * np.cos(pp), r * np.sin(pp), zz], axis=-1)
    return d, np.repeat(wz, n_phi) * (2 * np.pi / n_phi)


def gram(basis) -> np.ndarray:
    d, w = quadrature()
    y = basis(d)
    return (y * w[:, None]).T @ y


def orthonormality_error(basis) -> float:
    """The largest deviation of the Gram matrix from identity over the rows of bands 5..8."""
    g = gram(basis)
    return float(np.abs(g - np.eye(len(g)))[25:].max())


def test_bands_5_to_8_are_orthonormal():
    # bands 5..8 from float64 constants: the Gram rows are identity to rounding
    assert orthonormality_error(lambda d: shbasis.sh_basis(d, ORDER)) < 1e-12
    # bands 0..4 keep the paper's 6-digit literals (bands 0-2): identity to ~3e-6
    g = gram(lambda d: shbasis.sh_basis(d, ORDER))
    assert np.abs(g - np.eye(81)).max() < 1e-5


def test_a_wrong_band_7_constant_is_not_orthonormal(monkeypatch):
    table = shbasis.GENERIC_POLYNOMIALS[7].copy()
    table[5] *= 1.001  # one coefficient of N_7m P_7^(m), 0.1 % off
    monkeypatch.setitem(shbasis.GENERIC_POLYNOMIALS, 7, table)
    assert orthonormality_error(lambda d: shbasis.sh_basis(d, ORDER)) > 1e-4


def scipy_basis(d: np.ndarray, order: int, condon_shortley: bool = False) -> np.ndarray:
    """The real SH from scipy.special.lpmv (which includes the Condon-Shortley phase (-1)^m; removed here
    unless condon_shortley): Y_l0 = N P_l^0, Y_lm = sqrt2 N P_l^m cos(m phi), Y_l-m = sqrt2 N P_l^m sin(m phi)."""
    z = np.clip(d[..., 2], -1, 1)
    phi = np.arctan2(d[..., 1], d[..., 0])
    out = np.zeros(d.shape[:-1] + ((order + 1) ** 2,))
    for l in range(order + 1):
        for m in range(l + 1):
            n = np.sqrt((2 * l + 1) / (4 * np.pi) * factorial(l - m) / factorial(l + m))
            p = lpmv(m, l, z) * (1.0 if condon_shortley else (-1.0) ** m)
            k = l * l + l
            if m == 0:
                out[..., k] = n * p
            else:
                out[..., k + m] = np.sqrt(2) * n * p * np.cos(m * phi)
                out[..., k - m] = np.sqrt(2) * n * p * np.sin(m * phi)
    return out


def random_directions(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_bands_5_to_8_match_scipy_without_condon_shortley_phase():
    d = random_directions(400, seed=1)
    np.testing.assert_allclose(shbasis.sh_basis(d, ORDER)[:, 25:], scipy_basis(d, ORDER)[:, 25:], atol=1e-12)


def test_the_condon_shortley_phase_is_rejected():
    # negative control: scipy's phase kept flips every odd m; the comparison above sees it
    d = random_directions(400, seed=1)
    wrong = scipy_basis(d, ORDER, condon_shortley=True)[:, 25:]
    assert np.abs(shbasis.sh_basis(d, ORDER)[:, 25:] - wrong).max() > 0.1


def band_energies(coeffs: np.ndarray) -> np.ndarray:
    band = shbasis.band_of(ORDER)
    return np.bincount(band, weights=coeffs * coeffs, minlength=ORDER + 1)


def rotated_band_energies(basis, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Band energies of f = sum c_k Y_k and of f rotated (g(d) = f(R^T d)), both projected with `basis`."""
    rng = np.random.default_rng(seed)
    c = rng.normal(size=81)
    rot = Rotation.random(random_state=seed).as_matrix()
    d, w = quadrature()
    y = basis(d)
    f = basis(d @ rot) @ c  # f(R^T d): rows d @ R are R^T d
    projected = (y * w[:, None]).T @ f
    original = (y * w[:, None]).T @ (y @ c)
    return band_energies(original), band_energies(projected)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_band_energy_is_rotation_invariant(seed):
    e0, e1 = rotated_band_energies(lambda d: shbasis.sh_basis(d, ORDER), seed)
    # bands 0..4 carry the paper's rounded literals (~3e-6 relative); bands 5..8 rounding only
    np.testing.assert_allclose(e1[5:], e0[5:], rtol=1e-10)
    np.testing.assert_allclose(e1[:5], e0[:5], rtol=2e-5)


def test_a_wrong_band_7_constant_breaks_rotation_invariance(monkeypatch):
    table = shbasis.GENERIC_POLYNOMIALS[7].copy()
    table[5] *= 1.001
    monkeypatch.setitem(shbasis.GENERIC_POLYNOMIALS, 7, table)
    e0, e1 = rotated_band_energies(lambda d: shbasis.sh_basis(d, ORDER), 0)
    assert abs(e1[7] / e0[7] - 1) > 1e-6


def numerical_cosine_factor(l: int) -> float:
    """2 pi int_0^1 P_l(t) t dt by 20-point Gauss-Legendre on [0, 1] (exact for this degree <= 9 polynomial)."""
    x, w = legendre.leggauss(20)
    t, wt = (x + 1) / 2, w / 2
    return float(2 * np.pi * np.sum(wt * legendre.legval(t, np.eye(l + 1)[l]) * t))


def cosine_factor_errors(factors: np.ndarray) -> np.ndarray:
    return np.abs(factors - [numerical_cosine_factor(l) for l in range(ORDER + 1)])


def test_cosine_band_factors_to_band_8_are_the_integral():
    assert len(shbasis.COSINE_BAND_FACTORS) == ORDER + 1
    assert cosine_factor_errors(shbasis.COSINE_BAND_FACTORS).max() < 1e-14


def test_a_wrong_cosine_factor_is_rejected():
    wrong = shbasis.COSINE_BAND_FACTORS.copy()
    wrong[8] = -wrong[8]  # the sign of band 8
    assert cosine_factor_errors(wrong).max() > 1e-3


def test_order_8_counts_and_glsl_table():
    assert shbasis.count(8) == 81 and shbasis.order_of(81) == 8 and shbasis.order_of(64) == 7
    with pytest.raises(ValueError):
        shbasis.order_of(100)
    defs = dict(s.split(" ", 1) for s in shbasis.glsl_defines(8))
    assert defs["SH_COUNT"] == "81"
    values = np.array([float(v) for v in defs["SH_POLY"].removeprefix("float[](").removesuffix(")").split(",")])
    table = np.concatenate([shbasis.GENERIC_POLYNOMIALS[l] for l in range(5, 9)])
    np.testing.assert_allclose(values, table, rtol=1e-8, atol=0)  # 9 significant digits: float32 exact
    assert "SH_POLY" not in dict(s.split(" ", 1) for s in shbasis.glsl_defines(4))
