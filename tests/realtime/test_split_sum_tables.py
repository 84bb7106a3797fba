"""The split sum's numpy halves (realtime/techniques/split_sum/): the roughness <-> level mappings against the
engines' published formulas at hand values, the prefilter's sample sets against their own densities, the
DFG table's mirror against a deterministic quadrature written here, and the multiple-scattering
compensations' white furnace. No OpenGL."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.polynomial import legendre

from realtime.techniques.split_sum import dfg, ggx, mappings
from realtime.techniques.split_sum.ibl_fresnel import MULTISCATTER, ibl_fresnel
from realtime.techniques.split_sum.samples import prefilter_samples, sample_counts

MIN_ALPHA = 0.045 ** 2  # glTF's alpha = roughness^2 clamped at Filament's minimum perceptual roughness


# ------------------------------------------------------------------------------ an independent quadrature


def quadrature_ab(n_dot_v: float, roughness: float, kind: str = "height_correlated", nodes: int = 256):
    """(A, B) = (int (1 - Fc) f (n.l) dl, int Fc f (n.l) dl), f = D V, by a product rule over the half vector
    h (Gauss-Legendre in s with tan(theta_h) = alpha tan(pi s / 2), which spreads the nodes over the lobe
    at any alpha; the midpoint rule in phi) and the change of variables dl = 4 (v.h) dh. D and V are
    written here from glTF 2.0's Appendix B / Heitz 2014, apart from the code under test."""
    alpha = max(roughness * roughness, MIN_ALPHA)
    a2 = alpha * alpha
    x, w = legendre.leggauss(nodes)
    s, ws = 0.5 * (x + 1.0), 0.5 * w
    t = np.tan(np.pi * s / 2.0)
    theta = np.arctan(alpha * t)
    dtheta = alpha / (1.0 + (alpha * t) ** 2) * (np.pi / 2.0) / np.cos(np.pi * s / 2.0) ** 2
    phi = (np.arange(nodes) + 0.5) * 2.0 * np.pi / nodes
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    weight = (ws * dtheta)[:, None] * np.sin(th) * (2.0 * np.pi / nodes)
    h = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1)
    v = np.array([math.sqrt(1.0 - n_dot_v ** 2), 0.0, n_dot_v])
    vh = h @ v
    nl = (2.0 * vh[..., None] * h - v)[..., 2]
    nh = h[..., 2]
    ok = (nl > 0.0) & (vh > 0.0)
    nl = np.where(ok, nl, 1.0)
    d = a2 / (np.pi * (nh * nh * (a2 - 1.0) + 1.0) ** 2)
    lam_l, lam_v = np.sqrt(a2 + (1.0 - a2) * nl * nl), math.sqrt(a2 + (1.0 - a2) * n_dot_v ** 2)
    if kind == "height_correlated":
        vis = 0.5 / (n_dot_v * lam_l + nl * lam_v)
    else:
        vis = 1.0 / ((nl + lam_l) * (n_dot_v + lam_v))
    f = np.where(ok, d * vis * nl * 4.0 * vh, 0.0) * weight
    fc = (1.0 - np.clip(vh, 0.0, 1.0)) ** 5
    return float(np.sum(f * (1.0 - fc))), float(np.sum(f * fc))


def test_the_quadrature_has_the_closed_form_of_a_rough_lobe_seen_from_above():
    """At alpha = 1, D = 1/pi; at n.v = 1, V = 0.5 / (1 + n.l) (both Smith forms), so
    A + B = int_0^1 mu / (1 + mu) dmu = 1 - ln 2."""
    a, b = quadrature_ab(1.0, 1.0)
    assert a + b == pytest.approx(1.0 - math.log(2.0), abs=2e-5)


# ------------------------------------------------------------------------------ the DFG table's mirror


@pytest.mark.parametrize("roughness", [0.0, 0.1, 0.3, 0.6, 1.0])
def test_the_mirror_is_the_quadrature_within_its_sampling_error(roughness):
    """1024 Hammersley half vectors against the product rule: measured within 8e-3 at n.v = 0.05 and
    3.2e-3 above (r = 0.6 the worst)."""
    nv = np.array([0.05, 0.3, 0.7, 1.0])
    a, b = dfg.dfg_pair(nv, roughness, 1024)
    want = np.array([quadrature_ab(x, roughness) for x in nv])
    tol = np.array([1e-2, 5e-3, 5e-3, 5e-3])
    assert np.all(np.abs(a - want[:, 0]) <= tol) and np.all(np.abs(b - want[:, 1]) <= tol)


def test_a_and_b_tend_to_the_mirror_as_roughness_goes_to_zero():
    """Roughness 0 (alpha clamped at 0.045^2): A + B -> 1 (a mirror reflects everything) and B -> Fc's share
    (1 - n.v)^5 of it, for every n.v."""
    nv = np.array([0.2, 0.5, 0.9])
    a, b = dfg.dfg_pair(nv, 0.0, 1024)
    np.testing.assert_allclose(a + b, 1.0, atol=1e-3)
    np.testing.assert_allclose(b, (1.0 - nv) ** 5, atol=2e-3)


def test_the_table_is_indexed_by_n_dot_v_along_rows_at_texel_centres():
    """Texel [j, i] = the pair at n.v = (i + 0.5) / size, roughness = (j + 0.5) / size; its transpose (the
    axes swapped, a mutant) misses the quadrature by far more than the sampling error."""
    table = dfg.dfg_table(8, 256)
    i, j = 5, 2
    a, b = quadrature_ab((i + 0.5) / 8, (j + 0.5) / 8)
    assert abs(table[j, i, 0] - a) < 5e-3 and abs(table[j, i, 1] - b) < 5e-3
    assert abs(table[i, j, 0] - a) > 0.05


@pytest.mark.parametrize(("roughness", "nv"), [(0.6, 0.3), (1.0, 0.3)])
def test_the_visibility_terms_differ_where_the_quadrature_says(roughness, nv):
    """The separable Smith term (glTF's Appendix B as written) loses more energy than the height-correlated
    one every engine tabulates: 1.7 % at r = 0.6 and 8.8 % at r = 1, n.v = 0.3 (quadrature). Each mirror
    matches its own quadrature and misses the other one (the negative control)."""
    for kind, other in (("height_correlated", "separable"), ("separable", "height_correlated")):
        a, b = dfg.dfg_pair([nv], roughness, 4096, kind)
        own, cross = sum(quadrature_ab(nv, roughness, kind)), sum(quadrature_ab(nv, roughness, other))
        assert abs(a[0] + b[0] - own) < 3e-3 < abs(a[0] + b[0] - cross)


@pytest.mark.parametrize(("precision", "step"), [("f32", 1e-7), ("f16", 2.0 ** -11), ("u8", 1.0 / 255.0)])
def test_quantisation_rounds_to_the_stored_format(precision, step):
    rng = np.random.default_rng(3)
    x = rng.uniform(0.0, 1.0, 1000)
    q = dfg.quantise(x, precision)
    assert np.abs(q - x).max() <= 0.5 * step * 1.0001
    if precision == "u8":
        np.testing.assert_allclose(q * 255.0, np.round(q * 255.0), atol=1e-9)
        assert dfg.quantise(np.array([1.5, -0.2]), "u8").tolist() == [1.0, 0.0]


def test_lookup_is_bilinear_between_texel_centres_and_clamped_at_the_edges():
    t = np.zeros((4, 4, 1))
    t[1, 2, 0] = 1.0  # roughness centre 1.5 / 4, n.v centre 2.5 / 4
    assert dfg.lookup(t, 2.5 / 4, 1.5 / 4)[0] == pytest.approx(1.0)
    assert dfg.lookup(t, 2.0 / 4, 1.5 / 4)[0] == pytest.approx(0.5)
    assert dfg.lookup(t, 2.5 / 4, 1.0 / 4)[0] == pytest.approx(0.5)
    edge = np.arange(4.0)[None, :, None].repeat(4, axis=0)
    assert dfg.lookup(edge, 0.0, 0.5)[0] == 0.0 and dfg.lookup(edge, 1.0, 0.5)[0] == 3.0


# ------------------------------------------------------------------------------ the IBL Fresnel


@pytest.mark.parametrize("multiscatter", ["fdez_aguera", "threejs", "filament"])
def test_every_compensation_keeps_a_white_furnace_white(multiscatter):
    """F0 = 1: Ess + Ems = 1 for any (A, B) of a lobe; without compensation A + B < 1 (the control)."""
    a, b = dfg.dfg_pair(np.array([0.1, 0.5, 1.0]), 0.8, 512)
    for r in (0.3, 0.8, 1.0):
        np.testing.assert_allclose(ibl_fresnel(a, b, 1.0, r, np.array([0.1, 0.5, 1.0]), multiscatter), 1.0,
                                   rtol=1e-12)
    assert np.all(ibl_fresnel(a, b, 1.0, 0.8, 0.5, "none") < 0.9)


def test_khronos_fresnel_is_its_formula_at_a_hand_value():
    """Khronos' getIBLGGXFresnel at A = 0.5, B = 0.1, F0 = 0.04, roughness 0.5, n.v = 0.5 by hand:
    Fr = 0.46, k_S = 0.04 + 0.46 / 32 = 0.054375, FssEss = 0.1271875, Ems = 0.4, F_avg = 0.04 + 0.96 / 21,
    F_ibl = FssEss (1 + Ems F_avg / (1 - F_avg Ems)). Without the roughness-dependent term (three.js):
    FssEss = 0.12."""
    f_avg = 0.04 + 0.96 / 21.0
    want = 0.1271875 * (1.0 + 0.4 * f_avg / (1.0 - f_avg * 0.4))
    assert ibl_fresnel(0.5, 0.1, 0.04, 0.5, 0.5, "fdez_aguera") == pytest.approx(want, rel=1e-12)
    assert ibl_fresnel(0.5, 0.1, 0.04, 0.5, 0.5, "threejs") == pytest.approx(
        0.12 * (1.0 + 0.4 * f_avg / (1.0 - f_avg * 0.4)), rel=1e-12)
    assert ibl_fresnel(0.5, 0.1, 0.04, 0.5, 0.5, "filament") == pytest.approx(0.12 * (1.0 + 0.04 * (1 / 0.6 - 1)))
    assert ibl_fresnel(0.5, 0.1, [0.04, 1.0, 0.5], 0.5, 0.5, "none") == pytest.approx([0.12, 0.6, 0.35])
    assert set(MULTISCATTER) == {"none", "fdez_aguera", "threejs", "filament"}


# ------------------------------------------------------------------------------ the sample sets


@pytest.mark.parametrize("roughness", [0.0, 0.3, 1.0])
def test_vndf_with_n_equal_v_draws_the_same_directions_as_half_vector_sampling(roughness):
    """With V = N Heitz's visible normals have the half-vector density D(h) n.h, and for a power-of-two
    count the Hammersley set is symmetric in its two coordinates: both samplings give one set of
    directions. For 96 samples the two sets differ (control: the comparison can fail)."""
    def rows(sampling, n):
        r = prefilter_samples(roughness, n, 64, sampling)
        return r[np.lexsort(np.round(r[:, :3], 9).T)]

    np.testing.assert_allclose(rows("vndf", 256), rows("importance", 256), atol=1e-9)
    a, b = rows("vndf", 96), rows("importance", 96)
    assert a.shape != b.shape or np.abs(a - b).max() > 1e-3


@pytest.mark.parametrize("sampling", ["importance", "vndf"])
@pytest.mark.parametrize("roughness", [0.1, 0.5, 1.0])
def test_the_half_vectors_follow_ggx(sampling, roughness):
    """The half vectors' mean of tan^2 theta under D(h) n.h is infinite, but their CDF is closed:
    P(tan^2 theta <= alpha^2 x) = x / (1 + x). The empirical CDF of 4096 samples matches it at
    x = 0.25, 1, 4 within 1e-3 (the CDF of a lobe 1.5 times wider, 0.69 at x = 1, misses by > 0.05)."""
    alpha = max(roughness ** 2, MIN_ALPHA)
    h, _ = ggx.half_vectors(sampling, alpha, 4096)
    tan2 = (h[:, 0] ** 2 + h[:, 1] ** 2) / h[:, 2] ** 2
    for x in (0.25, 1.0, 4.0):
        assert np.mean(tan2 <= alpha ** 2 * x) == pytest.approx(x / (1.0 + x), abs=1e-3)
    assert abs(np.mean(tan2 <= (1.5 * alpha) ** 2) - 0.5) > 0.05


@pytest.mark.parametrize("roughness", [0.0, 0.25, 0.7])
def test_each_sample_reads_the_level_of_its_footprint(roughness):
    """A sample's FIS level is 0.5 log2(Omega_s / Omega_p), Omega_s = 1 / (N pdf(l)), pdf(l) = D(h) / 4 for
    n = v (h = normalize(n + l), D written here), Omega_p = 4 pi / (6 w^2). Sampled directions are unit
    and above the horizon. The half-vector density D (no / 4) shifts every level by exactly one (control)."""
    n, w = 64, 32
    s = prefilter_samples(roughness, n, w)
    lz = 1.0 - s[:, 2]
    np.testing.assert_allclose(s[:, 0] ** 2 + s[:, 1] ** 2 + lz ** 2, 1.0, atol=1e-12)
    assert np.all(lz > 0.0) and len(s) <= n
    alpha = max(roughness ** 2, MIN_ALPHA)
    cos_h = np.sqrt((1.0 + lz) / 2.0)
    d = alpha ** 2 / (np.pi * (cos_h ** 2 * (alpha ** 2 - 1.0) + 1.0) ** 2)
    omega_p = 4.0 * np.pi / (6.0 * w * w)
    expected = 0.5 * np.log2(1.0 / (n * d / 4.0) / omega_p)
    np.testing.assert_allclose(s[:, 3], expected, atol=1e-6)
    assert np.abs(s[:, 3] - 0.5 * np.log2(1.0 / (n * d) / omega_p) - 1.0).max() < 1e-6


def test_roughness_zero_is_a_finite_lobe_of_the_minimum_alpha():
    s = prefilter_samples(0.0, 1024, 256)
    assert np.all(np.isfinite(s)) and len(s) == 1024
    assert np.sqrt(s[:, 0] ** 2 + s[:, 1] ** 2).max() < 0.2  # all within ~11 degrees of n


def test_filaments_sample_count_doubles_from_level_two():
    assert sample_counts(5, 1024, 2) == [1024, 1024, 2048, 4096, 8192]
    assert sample_counts(3, 256, None) == [256, 256, 256]


# ------------------------------------------------------------------------------ the mappings


@pytest.mark.parametrize(("mapping", "roughness", "size", "levels", "lod"), [
    # Khronos: roughness (mip count - 1)
    ("linear", 0.5, 256, 5, 2.0), ("linear", 1.0, 256, 5, 4.0), ("linear", 0.3, 64, 3, 0.6),
    # Filament: (levels - 1) r (2 - r)
    ("filament", 0.5, 256, 5, 3.0), ("filament", 0.25, 256, 5, 1.75), ("filament", 1.0, 256, 5, 4.0),
    # three.js: log2(256) - roughnessToMip: r = 1 -> mip -2; 0.8 -> -1; 0.6 -> -1 + 3 (0.2 / 0.4) = 0.5;
    # 0.4 -> 2; 0.305 -> 3; 0.21 -> 4; 0.1 -> -2 log2(0.116) = 6.2166; 0.01 -> 12.9 clamped to 8
    ("threejs", 1.0, 256, 11, 10.0), ("threejs", 0.8, 256, 11, 9.0), ("threejs", 0.6, 256, 11, 7.5),
    ("threejs", 0.4, 256, 11, 6.0), ("threejs", 0.305, 256, 11, 5.0), ("threejs", 0.21, 256, 11, 4.0),
    ("threejs", 0.1, 256, 11, 8.0 + 2.0 * math.log2(0.116)), ("threejs", 0.01, 256, 11, 0.0),
    # Babylon: 0.8 log2(width alpha): alpha = 0.25 -> 0.8 log2(64) = 4.8; alpha = 1 -> 6.4;
    # roughness 0.1 -> alpha 0.01 -> 0.8 log2(2.56); roughness 0 -> alpha 0.045^2 -> log2 < 0 -> 0
    ("babylon", 0.5, 256, 9, 4.8), ("babylon", 1.0, 256, 9, 6.4), ("babylon", 0.1, 256, 9, 0.8 * math.log2(2.56)),
    ("babylon", 0.0, 256, 9, 0.0),
])
def test_each_mapping_is_its_published_formula(mapping, roughness, size, levels, lod):
    assert mappings.lod(mapping, roughness, size, levels) == pytest.approx(lod, abs=1e-12)


@pytest.mark.parametrize(("mapping", "size", "min_size"), [("linear", 256, 16), ("filament", 256, 16),
                                                           ("threejs", 256, 16), ("babylon", 256, 1),
                                                           ("linear", 32, 1), ("filament", 64, 4),
                                                           ("threejs", 32, 16), ("babylon", 32, 1)])
def test_each_level_is_read_at_its_own_index(mapping, size, min_size):
    """mapping o inverse = identity: the roughness level k is prefiltered with is read at lod k exactly
    (k >= 1; level 0 holds roughness 0, read at lod 0 by every mapping)."""
    levels = mappings.chain_levels(mapping, size, min_size)
    n = len(levels)
    for k in range(n):
        assert mappings.lod(mapping, levels[k].roughness, size, n) == pytest.approx(k, abs=1e-9), k
    roughnesses = [lv.roughness for lv in levels]
    assert roughnesses[0] == 0.0 and roughnesses == sorted(roughnesses)


def test_a_wrong_inverse_is_caught():
    """Control: Filament's level roughness read through the linear mapping (Khronos') misses its index."""
    levels = mappings.chain_levels("filament", 256, 16)
    misses = [abs(mappings.lod("linear", lv.roughness, 256, 5) - k) for k, lv in enumerate(levels)]
    assert max(misses) > 0.5


@pytest.mark.parametrize("r", [0.05, 0.2, 0.5, 0.77, 0.95])
def test_roughness_survives_the_round_trip(r):
    """inverse o mapping = identity where the mapping is invertible: roughness -> lod -> roughness."""
    for mapping in ("linear", "filament"):
        x = mappings.lod(mapping, r, 256, 5)
        back = x / 4 if mapping == "linear" else 1.0 - math.sqrt(1.0 - x / 4)
        assert back == pytest.approx(r, abs=1e-12)
    assert mappings.threejs_mip_to_roughness(mappings.threejs_roughness_to_mip(r)) == pytest.approx(r, abs=1e-12)


def test_chain_sizes_follow_each_engines_layout():
    """Khronos / Filament: 256 ... 16 (5 levels); three.js: 256 ... 16 and six more at 16 (11); Babylon:
    256 ... 1 (9); per_material: one base-size level per distinct roughness."""
    assert [lv.size for lv in mappings.chain_levels("linear", 256, 16)] == [256, 128, 64, 32, 16]
    assert [lv.size for lv in mappings.chain_levels("threejs", 256, 16)] == [256, 128, 64, 32, 16] + [16] * 6
    assert [lv.size for lv in mappings.chain_levels("babylon", 256, 1)] == [256 >> k for k in range(9)]
    per = mappings.chain_levels("per_material", 64, 16, [0.5, 0.1, 0.5])
    assert per == (mappings.Level(0.1, 64), mappings.Level(0.5, 64))
    assert mappings.read_levels("per_material", 0.5, per, 64) == (1, 1, 0.0)
    with pytest.raises(ValueError, match="no level of its own"):
        mappings.read_levels("per_material", 0.3, per, 64)


def test_an_object_reads_the_two_levels_around_its_lod():
    levels = mappings.chain_levels("linear", 256, 16)
    assert mappings.read_levels("linear", 0.3, levels, 256) == (1, 2, pytest.approx(0.2))
    assert mappings.read_levels("linear", 1.0, levels, 256) == (4, 4, 0.0)


def test_the_exact_texel_sum_weighs_each_texel_by_d_n_dot_l_and_its_solid_angle():
    """reference.ggx_texel_weights against D(h) (n.w) dOmega(w) written here (h = normalize(n + w),
    D = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)), normalised; zero below the horizon. A constant map's
    texel sum is the constant."""
    from realtime.techniques.split_sum.reference import ggx_convolve_numpy, ggx_texel_weights
    from scenes.environment import cubemap

    n = cubemap.texel_directions(4).reshape(-1, 3)[::5]
    w = cubemap.texel_directions(8).reshape(-1, 3)
    omega = np.tile(cubemap.texel_solid_angles(8).reshape(-1), 6)
    for roughness in (0.2, 0.7):
        alpha = max(roughness ** 2, MIN_ALPHA)
        h = n[:, None, :] + w[None, :, :]
        nh = np.sum(n[:, None, :] * h, axis=-1) / np.linalg.norm(h, axis=-1)
        d = alpha ** 2 / (np.pi * (nh ** 2 * (alpha ** 2 - 1.0) + 1.0) ** 2)
        k = d * np.maximum(n @ w.T, 0.0) * omega
        np.testing.assert_allclose(ggx_texel_weights(8, n, roughness).reshape(len(n), -1),
                                   k / k.sum(axis=1, keepdims=True), rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(ggx_convolve_numpy(np.full((6, 8, 8, 3), 2.5), n, 0.0), 2.5, rtol=1e-12)
