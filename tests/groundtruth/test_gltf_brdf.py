"""groundtruth.exact.gltf_brdf against the glTF 2.0 specification's text (tests/groundtruth/gltf_spec.py, written
apart), closed forms worked out by hand, scipy's adaptive quadrature and seeded Monte Carlo.

The quadrature reference normalises each kernel by these albedos, so they are checked here on their own: D's
normalisation, V's two limits, the whole f, its reciprocity, the split of f (n.l) into the kernels the
quadrature integrates, and E, A, B, Lambert against estimates that share no code with the rule."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from groundtruth.exact import gltf_brdf
from scenes.model import materials
from tests.groundtruth.gltf_spec import frame, mc_albedo, spec_f

ALPHAS = [materials.PBR_MIN_ALPHA, 0.01, 0.1, 0.5, 1.0]


def random_pairs(count: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(n, v, l) unit vectors with n.v > 0 and n.l > 0."""
    rng = np.random.default_rng(seed)

    def unit(k):
        x = rng.normal(size=(k, 3))
        return x / np.linalg.norm(x, axis=1, keepdims=True)

    n, v, l = unit(count), unit(count), unit(count)
    v = np.where(np.sum(n * v, 1, keepdims=True) < 0, -v, v)
    l = np.where(np.sum(n * l, 1, keepdims=True) < 0, -l, l)
    return n, v, l


# --------------------------------------------------------------------------- D and V


def ggx_mass(d_of_cos, alpha: float) -> float:
    """int D(n.h) (n.h) dh over the hemisphere = 2 pi int_0^{pi/2} D(cos t) cos t sin t dt, by scipy's adaptive
    quadrature with breakpoints where the lobe turns (t ~ alpha)."""
    pts = [p for p in (alpha, 3 * alpha, 10 * alpha, 100 * alpha) if p < 1.5]
    val, _ = integrate.quad(lambda t: d_of_cos(math.cos(t)) * math.cos(t) * math.sin(t), 0.0, math.pi / 2,
                            points=pts, limit=400, epsabs=1e-13, epsrel=1e-11)
    return 2.0 * math.pi * val


@pytest.mark.parametrize("alpha", ALPHAS)
def test_ggx_distribution_integrates_to_one(alpha):
    """The projected microfacet area is the macro-surface's: int D (n.h) dh = 1 (Trowbridge-Reitz's normalisation)."""
    assert ggx_mass(lambda c: float(gltf_brdf.D_ggx(np.array(c), alpha)), alpha) == pytest.approx(1.0, abs=1e-8)


def test_control_ggx_with_alpha_for_alpha_squared_is_not_normalised():
    wrong = lambda c: 0.1 / (math.pi * (c * c * (0.01 - 1.0) + 1.0) ** 2)  # noqa: E731  alpha in the numerator
    assert abs(ggx_mass(wrong, 0.1) - 1.0) > 1.0


@pytest.mark.parametrize(("nl", "nv", "value"), [
    # alpha = 1: sqrt(1 + 0 * x^2) = 1, V = 1 / (2 (nv + nl))
    (0.5, 0.25, 1.0 / (2 * 0.75)),
    (1.0, 1.0, 0.25),
    (0.1, 0.9, 0.5),
])
def test_visibility_at_alpha_one_by_hand(nl, nv, value):
    assert float(gltf_brdf.V_smith_ggx_correlated(np.array(nl), np.array(nv), 1.0)) == pytest.approx(value, rel=1e-14)


def separable_v(nl, nv, alpha):
    """G1(L) G1(V) / (4 n.l n.v), G1(X) = 2 n.x / (n.x + sqrt(alpha^2 + (1 - alpha^2)(n.x)^2))."""
    a2 = alpha * alpha
    return 1.0 / ((nl + np.sqrt(a2 + (1 - a2) * nl * nl)) * (nv + np.sqrt(a2 + (1 - a2) * nv * nv)))


@pytest.mark.parametrize("alpha", ALPHAS)
def test_visibility_is_the_separable_form_where_one_direction_is_the_normal(alpha):
    """Height correlation (Heitz 2014) 1 / (1 + Lambda_l + Lambda_v) is 1 / ((1 + Lambda_l)(1 + Lambda_v)) when a
    Lambda vanishes, i.e. along the normal; elsewhere it is larger (less shadowing than the product)."""
    nv = np.linspace(0.01, 1.0, 50)
    one = np.ones_like(nv)
    v_corr = gltf_brdf.V_smith_ggx_correlated
    np.testing.assert_allclose(v_corr(one, nv, alpha), separable_v(one, nv, alpha), rtol=1e-13)
    np.testing.assert_allclose(v_corr(nv, one, alpha), separable_v(nv, one, alpha), rtol=1e-13)
    oblique = gltf_brdf.V_smith_ggx_correlated(nv[:-1], nv[:-1], alpha)
    assert np.all(oblique >= separable_v(nv[:-1], nv[:-1], alpha) * (1 - 1e-13))


def test_control_separable_form_misses_the_hand_case():
    # the pre-2.0.1 product at alpha = 1, n.l = 0.5, n.v = 0.25: 1 / (1.5 * 1.25) = 0.533, not 2/3
    assert abs(separable_v(0.5, 0.25, 1.0) - 1.0 / 1.5) > 0.1


# --------------------------------------------------------------------------- the whole f


MATERIALS = [((0.8, 0.3, 0.1), 0.0, 0.5), ((0.95, 0.64, 0.54), 1.0, 0.2), ((0.2, 0.9, 0.5), 0.4, 0.0),
             ((1.0, 1.0, 1.0), 0.7, 1.0), ((0.0, 0.0, 0.0), 0.0, 0.05)]


@pytest.mark.parametrize(("base", "metallic", "roughness"), MATERIALS)
def test_brdf_is_the_spec_text(base, metallic, roughness):
    n, v, l = random_pairs(4000, 7)
    np.testing.assert_allclose(gltf_brdf.brdf(base, metallic, roughness, n, v, l),
                               spec_f(base, metallic, roughness, n, v, l), rtol=1e-10, atol=1e-300)


def test_control_fresnel_of_n_dot_v_is_not_the_spec():
    n, v, l = random_pairs(2000, 8)
    base = np.array([0.95, 0.64, 0.54])
    nv = np.sum(n * v, -1)
    h = (v + l) / np.linalg.norm(v + l, axis=1, keepdims=True)
    spec = spec_f(base, 1.0, 0.3, n, v, l)
    f_vh = base + (1 - base) * (1 - np.sum(v * h, -1))[:, None] ** 5
    wrong = spec / f_vh * (base + (1 - base) * (1 - nv)[:, None] ** 5)
    assert np.abs(wrong / spec - 1).max() > 0.1


@pytest.mark.parametrize(("base", "metallic", "roughness"), MATERIALS)
def test_brdf_is_reciprocal(base, metallic, roughness):
    """f(v, l) = f(l, v): D and V are symmetric and the Fresnel term reads |v.h| = |l.h|."""
    n, v, l = random_pairs(4000, 9)
    np.testing.assert_allclose(gltf_brdf.brdf(base, metallic, roughness, n, v, l),
                               gltf_brdf.brdf(base, metallic, roughness, n, l, v), rtol=1e-12, atol=1e-300)


def test_control_fresnel_of_the_view_cosine_is_not_reciprocal():
    n, v, l = random_pairs(2000, 10)

    def wrong(v, l):  # a metal whose Fresnel reads n.v, as the paper's blend does
        return (gltf_brdf.brdf((1, 1, 1), 1.0, 0.4, n, v, l)[:, 0]
                * gltf_brdf.fresnel_schlick(0.2, np.sum(n * v, -1)))
    assert np.abs(wrong(v, l) / wrong(l, v) - 1).max() > 0.1


def test_brdf_cos_is_one_sided_and_cut_at_the_horizon():
    n, v, l = random_pairs(500, 11)
    args = ((0.5, 0.5, 0.5), 0.3, 0.4)
    assert np.all(gltf_brdf.brdf_cos(*args, n, v, l) > 0)
    assert np.all(gltf_brdf.brdf_cos(*args, n, -v, l) == 0)  # viewer behind the surface
    assert np.all(gltf_brdf.brdf_cos(*args, n, v, -l) == 0)  # light below the horizon


@pytest.mark.parametrize(("base", "metallic", "roughness"), MATERIALS)
def test_kernels_recompose_the_brdf(base, metallic, roughness):
    """f (n.l) = [f0 (1 - w) + w] K + kd (1 - w)(n.l) / pi, the split the quadrature integrates (expanding the
    spec's two mixes: the specular weight (1 - m)(0.04 + 0.96 w) + m (b + (1 - b) w) = f0 + (1 - f0) w,
    the diffuse (1 - m)(1 - 0.04 - 0.96 w) b = (1 - m) 0.96 b (1 - w))."""
    n, v, l = random_pairs(3000, 12)
    nl, nv, vl = np.sum(n * l, -1), np.sum(n * v, -1), np.sum(v * l, -1)
    k, w = gltf_brdf.kernels(nv, nl, vl, gltf_brdf.alpha_of(roughness))
    f0, kd = gltf_brdf.colour_weights(base, metallic)
    got = (f0 * (1 - w)[:, None] + w[:, None]) * k[:, None] + kd * ((1 - w) * nl / np.pi)[:, None]
    np.testing.assert_allclose(got, spec_f(base, metallic, roughness, n, v, l) * nl[:, None], rtol=1e-8, atol=1e-300)
    # sin^2(theta_h) passed in (float32's path) gives the same kernel
    hv = v + l
    sin2 = np.sum(np.cross(n, hv) ** 2, -1) / np.sum(hv * hv, -1)
    np.testing.assert_allclose(gltf_brdf.kernels(nv, nl, vl, gltf_brdf.alpha_of(roughness), sin2)[0], k, rtol=1e-8)


def test_control_kernels_with_the_fresnel_weights_swapped_do_not_recompose():
    n, v, l = random_pairs(2000, 13)
    nl, nv, vl = np.sum(n * l, -1), np.sum(n * v, -1), np.sum(v * l, -1)
    k, w = gltf_brdf.kernels(nv, nl, vl, gltf_brdf.alpha_of(0.3))
    f0, _ = gltf_brdf.colour_weights((0.9, 0.5, 0.1), 1.0)
    wrong = (f0 * w[:, None] + (1 - w)[:, None]) * k[:, None]
    assert np.abs(wrong / (spec_f((0.9, 0.5, 0.1), 1.0, 0.3, n, v, l) * nl[:, None]) - 1).max() > 0.5


# --------------------------------------------------------------------------- E, A, B, Lambert


MC_CASES = [(0.9, 0.0), (0.4, 0.0), (0.9, 0.1), (0.2, 0.1), (0.7, 0.3), (0.15, 0.5), (0.5, 0.5), (1.0, 1.0),
            (0.05, 1.0)]


@pytest.mark.parametrize(("mu", "roughness"), MC_CASES)
def test_directional_albedo_against_monte_carlo(mu, roughness):
    """E(mu) = int V D (n.l) dl: the spec's f of a white metal (f0 = 1: F = 1), integrated by seeded Monte Carlo;
    within 4 standard errors (2e5 samples: ~1e-3)."""
    est, se = mc_albedo((1.0, 1.0, 1.0), 1.0, roughness, mu, 200_000, seed=int(mu * 100 + roughness * 10))
    e = float(gltf_brdf.directional_albedo(mu, roughness)[0])
    assert abs(e - est[0]) < 4 * se[0] + 1e-6, (e, est[0], se[0])


def test_control_albedo_of_the_separable_visibility_is_rejected(monkeypatch):
    # the same check against a rule whose V is the product G1 G1 (0.511 instead of 0.642 at roughness 1, mu = 0.2)
    monkeypatch.setattr(gltf_brdf, "V_smith_ggx_correlated",
                        lambda nl, nv, alpha, *_: separable_v(np.abs(nl), np.abs(nv), alpha))
    est, se = mc_albedo((1.0, 1.0, 1.0), 1.0, 1.0, 0.2, 200_000, seed=55)
    e = float(gltf_brdf.directional_albedo(0.2, 1.0)[0])
    assert abs(e - est[0]) > 4 * se[0] + 1e-6


def test_directional_albedo_at_alpha_one_in_closed_form():
    """alpha = 1: D = 1 / pi and V = 1 / (2 (mu + n.l)), so E = int nl / (2 pi (mu + nl)) dl = int_0^1 x / (mu + x) dx
    = 1 - mu ln(1 + 1 / mu) (every l: h.l = h.v > 0 on the hemisphere)."""
    mu = np.array([1.0, 0.7, 0.5, 0.2, 0.05, 1e-3, 1e-6])
    exact = 1 - mu * np.log1p(1 / mu)
    got = gltf_brdf.directional_albedo(mu, 1.0)
    np.testing.assert_allclose(got[:5], exact[:5], rtol=1e-10)
    np.testing.assert_allclose(got[5:], exact[5:], atol=1e-6)  # the rule's own error where n.l ~ mu is tiny
    # the control: the separable product's closed form, int_0^1 2x / ((x + 1)(mu + 1)) dx = 2 (1 - ln 2) / (1 + mu)
    assert np.abs(2 * (1 - math.log(2)) / (1 + mu) - (1 - mu * np.log1p(1 / mu))).max() > 0.05


def test_directional_albedo_limits():
    """A mirror seen head on reflects all: E(1) -> 1 as alpha -> 0 (Smith's Lambda(n) = 0; at alpha_min the
    lobe loses 4e-6). At grazing every alpha gives E(0) = 1: with mu = 0, V = 1 / (2 alpha n.l), and in the GGX CDF
    u = sin^2 x (tan t = alpha tan x) E = (1 / pi) int_0^1 du int_{|p| < pi/2} tan(t) cos(p) / alpha dp
    = (2 / pi) int_0^1 sqrt(u / (1 - u)) du = 1."""
    assert float(gltf_brdf.directional_albedo(1.0, 0.0)[0]) == pytest.approx(1.0, abs=1e-5)
    np.testing.assert_allclose(gltf_brdf.directional_albedo(np.zeros(len(ALPHAS)), 0.0), 1.0, atol=1e-9)
    for roughness in (0.0, 0.1, 0.5, 1.0):
        assert float(gltf_brdf.directional_albedo(0.0, roughness)[0]) == pytest.approx(1.0, abs=1e-7)


def test_dfg_pair_by_hand_and_its_sum():
    """As alpha -> 0 the half vector is n, so v.h = mu: A -> E (1 - (1 - mu)^5), B -> E (1 - mu)^5 with E -> 1
    (alpha_min: within 1e-4). A + B = E for F0 = 1 (Karis: int f cos = F0 A + B)."""
    a, b = gltf_brdf.dfg(0.5, 0.0)
    assert float(a[0]) == pytest.approx(1 - 0.5 ** 5, abs=1e-4)
    assert float(b[0]) == pytest.approx(0.5 ** 5, abs=1e-4)
    mu = np.linspace(0.0, 1.0, 11)
    for roughness in (0.0, 0.3, 1.0):
        a, b = gltf_brdf.dfg(mu, roughness)
        np.testing.assert_allclose(a + b, gltf_brdf.directional_albedo(mu, roughness), rtol=1e-14)
        assert np.all(b >= 0) and np.all(a >= b * 0)
    # the control: the pair swapped misses the hand case
    assert abs(float(gltf_brdf.dfg(0.5, 0.0)[1][0]) - (1 - 0.5 ** 5)) > 0.5


@pytest.mark.parametrize(("base", "metallic", "roughness", "mu"), [
    ((0.2, 0.5, 0.9), 0.0, 0.3, 0.8), ((0.2, 0.5, 0.9), 0.5, 0.7, 0.3), ((0.95, 0.64, 0.54), 1.0, 0.3, 0.5),
    ((1.0, 1.0, 1.0), 0.0, 0.0, 0.1), ((0.0, 0.0, 0.0), 0.0, 0.6, 0.6)])
def test_material_albedo_against_monte_carlo(base, metallic, roughness, mu):
    """f0 A + B + kd Lambert, per channel, against the spec's f integrated by seeded Monte Carlo (4 standard errors)."""
    est, se = mc_albedo(base, metallic, roughness, mu, 200_000, seed=3)
    got = gltf_brdf.albedo(base, metallic, roughness, mu)[0]
    assert np.all(np.abs(got - est) < 4 * se + 1e-6), (got, est, se)


def test_lambert_albedo_at_normal_incidence():
    """mu = 1: v.h = cos(theta_l / 2), so Lambert(1) = 2 int_0^{pi/2} cos t sin t (1 - (1 - cos(t/2))^5) dt."""
    val, _ = integrate.quad(lambda t: 2 * math.cos(t) * math.sin(t) * (1 - (1 - math.cos(t / 2)) ** 5), 0, math.pi / 2,
                            epsabs=1e-14)
    assert float(gltf_brdf.lambert_albedo(1.0)[0]) == pytest.approx(val, abs=1e-12)
    assert abs(val - 1.0) > 5e-5  # the control: the weight is there (Lambert alone would be 1)


def test_energy_of_a_white_metal_and_of_a_white_dielectric():
    """A white metal reflects at most what it receives (E <= 1: G2 <= G1 <= 1). A white dielectric does not: the
    spec's fresnel_mix weights the Lambert lobe by 1 - F(v.h), which stays ~0.95 at grazing while the specular
    lobe's F(mu) rises to 1 (the spec itself says fresnel_mix "breaks ... energy conservation"); the Monte Carlo
    case (1, 1, 1), roughness 0, mu = 0.1 above checks that value independently."""
    mu = np.linspace(0.0, 1.0, 41)
    for roughness in (0.0, 0.1, 0.3, 0.5, 0.8, 1.0):
        assert np.all(gltf_brdf.directional_albedo(mu, roughness) <= 1.0 + 1e-9)
    white = gltf_brdf.albedo((1, 1, 1), 0.0, 0.0, np.array([0.1]))[0, 0]
    assert white > 1.5


def test_tables_match_the_direct_rule():
    """The quadrature reads A, B, Lambert from per-panel Chebyshev tables: within 1e-8 of the direct rule down to
    mu = 1e-13 (E has a mu ln mu term at grazing, which panels halving towards 0 resolve)."""
    rng = np.random.default_rng(4)
    mu = np.concatenate([rng.uniform(0, 1, 60), 10 ** rng.uniform(-13, -1, 40), [0.0, 1.0, 0.5]])
    for roughness in (0.0, 0.1, 0.5, 1.0):
        alpha = gltf_brdf.alpha_of(roughness)
        a, b = gltf_brdf.dfg_interpolated(mu, alpha)
        a0, b0 = gltf_brdf.dfg(mu, roughness)
        np.testing.assert_allclose(a, a0, atol=1e-8)
        np.testing.assert_allclose(b, b0, atol=1e-8)
    np.testing.assert_allclose(gltf_brdf.lambert_interpolated(mu), gltf_brdf.lambert_albedo(mu), atol=1e-12)


def test_control_one_chebyshev_series_over_all_mu_misses_grazing():
    x = np.cos(np.pi * (np.arange(65) + 0.5) / 65)
    mu_nodes = np.cos(0.25 * np.pi * (x + 1))
    coef = np.polynomial.chebyshev.chebfit(x, gltf_brdf.directional_albedo(mu_nodes, 0.0), 64)
    mu = np.array([1e-3, 3e-3, 1e-2])
    approx = np.polynomial.chebyshev.chebval(np.arccos(mu) * 4 / np.pi - 1, coef)
    assert np.abs(approx - gltf_brdf.directional_albedo(mu, 0.0)).max() > 1e-4


def test_no_nan_at_the_extremes():
    n = np.array([0.0, 0.0, 1.0])
    grazing = np.array([math.sqrt(1 - 1e-18), 0.0, 1e-9])
    cases = [(n, n), (n, grazing), (grazing, grazing), (grazing, -grazing * [1, 1, -1]), (n, -n), (grazing, n)]
    for v, l in cases:
        for base in ((0, 0, 0), (1, 1, 1)):
            for roughness in (0.0, 1.0):
                assert np.all(np.isfinite(gltf_brdf.brdf(base, 0.5, roughness, n, v, l)))
                assert np.all(np.isfinite(gltf_brdf.brdf_cos(base, 0.5, roughness, n, v, l)))
    mu = np.array([0.0, 1e-12, 1.0])
    assert np.all(np.isfinite(gltf_brdf.dfg(mu, 0.0))) and np.all(np.isfinite(gltf_brdf.lambert_albedo(mu)))
    k, w = gltf_brdf.kernels(np.float32(1e-9), np.float32([0.0, 1e-9, 1.0]), np.float32([-1.0, 0.0, 1.0]), 2e-3)
    assert np.all(np.isfinite(k)) and np.all(np.isfinite(w)) and k.dtype == np.float32
    assert frame(1.0)[1][2] == 1.0
