"""The `iblcheck_paper` plugin: its values against docs/contract.md section 3 written out here, and its
sampling against Mitsuba's own chi-square test (`mitsuba.chi2`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from groundtruth.pathtracer import paper_bsdf
from scenes.model.scene import Material

pytestmark = pytest.mark.mitsuba

CASES = [  # (material, wi): several (kd, ks, N, f0), N up to 1e4, normal and oblique views
    (Material("diffuse", kd=(0.7, 0.5, 0.3)), (0.3, 0.0, 0.954)),
    (Material("phong", ks=(1.0, 1.0, 1.0), exponent=1.0), (0.6, 0.0, 0.8)),
    (Material("phong", ks=(0.9, 0.9, 0.9), exponent=50.0), (0.0, 0.0, 1.0)),
    (Material("phong", ks=(1.0, 1.0, 1.0), exponent=1e4), (0.6, 0.0, 0.8)),
    (Material("blend", kd=(0.5, 0.5, 0.5), ks=(1.0, 1.0, 1.0), exponent=10.0, f0=0.04), (0.3, 0.0, 0.954)),
    (Material("blend", kd=(0.8, 0.2, 0.2), ks=(1.0, 1.0, 1.0), exponent=1000.0, f0=0.5), (0.8, 0.0, 0.6)),
    (Material("blend", kd=(0.8, 0.8, 0.8), ks=(1.0, 1.0, 1.0), exponent=200.0, f0=1.0), (0.95, 0.0, 0.312)),
]


def _adapters(mi, material, wi):
    from mitsuba.chi2 import BSDFAdapter

    paper_bsdf.register(mi)
    wi = np.asarray(wi, dtype=float) / np.linalg.norm(wi)
    return BSDFAdapter(paper_bsdf.PLUGIN_NAME, paper_bsdf.material_dict(material), wi=mi.ScalarVector3f(*wi))


@pytest.mark.parametrize(("material", "wi"), CASES, ids=lambda c: getattr(c, "type", None) and
                         f"{c.type}-N{c.exponent:g}-f0{c.f0:g}")
def test_sampling_passes_mitsubas_chi2(mi, material, wi):
    from mitsuba.chi2 import ChiSquareTest, SphericalDomain

    sample, pdf = _adapters(mi, material, wi)
    res = 401 if material.exponent >= 5000 else 201
    test = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf, sample_dim=3, res=res, ires=32)
    assert test.run(), test.messages


def test_chi2_rejects_a_wrong_pdf(mi):
    """Negative control: sampling N = 100 against the pdf of N = 130 must fail the same test."""
    from mitsuba.chi2 import ChiSquareTest, SphericalDomain

    sample, _ = _adapters(mi, Material("phong", exponent=100.0), (0.3, 0.0, 0.954))
    _, wrong_pdf = _adapters(mi, Material("phong", exponent=130.0), (0.3, 0.0, 0.954))
    test = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=wrong_pdf, sample_dim=3, res=201)
    assert not test.run(quiet=True)


def _eval(mi, material, wi, wo):
    import drjit as dr

    paper_bsdf.register(mi)
    bsdf = mi.load_dict(paper_bsdf.material_dict(material))
    si = dr.zeros(mi.SurfaceInteraction3f, len(wo))
    si.wi = mi.Vector3f(*[np.full(len(wo), c) for c in wi])
    ctx = mi.BSDFContext()
    w = mi.Vector3f(wo[:, 0], wo[:, 1], wo[:, 2])
    return np.array(bsdf.eval(ctx, si, w)).T, np.array(bsdf.pdf(ctx, si, w))


def _design_formula(material, wi, wo):
    """f cos of docs/contract.md section 3, written out independently of the plugin and reflectance.py."""
    cos_o = wo[:, 2]
    if wi[2] <= 0:  # one-sided: a viewer behind the shading normal sees black
        return np.zeros((len(wo), 3))
    c = min(max(wi[2], 0.0), 1.0)
    F = {"diffuse": 0.0, "phong": 1.0}.get(material.type, material.f0 + (1 - material.f0) * (1 - c) ** 5)
    r = np.array([-wi[0], -wi[1], wi[2]])
    lobe = (material.exponent + 1) / (2 * math.pi) * np.maximum(wo @ r, 0.0) ** material.exponent
    kd = np.asarray(material.kd) if material.type != "phong" else np.zeros(3)
    ks = np.asarray(material.ks) if material.type != "diffuse" else np.zeros(3)
    value = (1 - F) * kd[None] / math.pi * np.maximum(cos_o, 0)[:, None] + F * ks[None] * lobe[:, None]
    return np.where((cos_o > 0)[:, None], value, 0.0)


BACK_FACING = (Material("blend", exponent=20.0, f0=0.2), (0.0, 0.6, -0.8))  # a silhouette's shading normal


@pytest.mark.parametrize(("material", "wi"), CASES[:-1] + [BACK_FACING])
def test_eval_matches_the_design_formula(mi, rng, material, wi):
    wi = np.asarray(wi) / np.linalg.norm(wi)
    wo = rng.normal(size=(2000, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    # plus directions close to the mirror direction, where a narrow lobe lives
    r = np.array([-wi[0], -wi[1], wi[2]])
    near = r + 0.3 / math.sqrt(material.exponent + 1) * rng.normal(size=(500, 3))
    wo = np.concatenate([wo, near / np.linalg.norm(near, axis=1, keepdims=True)])
    value, pdf = _eval(mi, material, wi, wo)
    expected = _design_formula(material, wi, wo)
    np.testing.assert_allclose(value, expected, rtol=2e-3, atol=1e-5 * max(1.0, expected.max()))
    assert np.isfinite(pdf).all() and (pdf >= 0).all()
    assert (pdf[wo[:, 2] <= 0] == 0).all()
    if wi[2] <= 0:
        return  # a viewer behind the shading normal: the back-face rule, not this test's
    # the pdf is the mixture the sampler draws from: the cosine lobe with probability p_d, the Phong lobe
    # otherwise, p_d = (1 - F) mean(kd) / ((1 - F) mean(kd) + F mean(ks)) (lobe energies as sampling weights)
    c = min(max(wi[2], 0.0), 1.0)
    F = {"diffuse": 0.0, "phong": 1.0}.get(material.type, material.f0 + (1 - material.f0) * (1 - c) ** 5)
    wd = (1 - F) * (np.mean(material.kd) if material.type != "phong" else 0.0)
    wg = F * (np.mean(material.ks) if material.type != "diffuse" else 0.0)
    p_d = wd / (wd + wg) if wd + wg > 0 else 1.0
    r = np.array([-wi[0], -wi[1], wi[2]])
    lobe = (material.exponent + 1) / (2 * math.pi) * np.maximum(wo @ r, 0.0) ** material.exponent
    expected_pdf = np.where(wo[:, 2] > 0, p_d * np.maximum(wo[:, 2], 0) / math.pi + (1 - p_d) * lobe, 0.0)
    np.testing.assert_allclose(pdf, expected_pdf, rtol=2e-3, atol=1e-5 * max(1.0, expected_pdf.max()))


@pytest.mark.parametrize("exponent", [0.0, 1.0, 1e4, 1e6])
@pytest.mark.parametrize("cos_i", [1.0, 0.3, 1e-4, 0.0, -0.2])
def test_sample_weights_are_f_cos_over_pdf_and_average_to_the_albedo(mi, exponent, cos_i):
    """Extreme exponents and grazing or back-facing views. Each sample's weight is f cos / pdf at the
    direction it returns (eval and pdf asked again there) and finite, its pdf is `pdf` there, and for a
    viewer in front (cos_i > 0) the mean weight is the directional albedo written out by hand:
    (1 - F) kd + F ks frac, frac the part of the lobe about the mirror direction above the horizon
    (common.horizon_fraction, cos(n, r) = cos_i), F Schlick's at cos_i. Tolerance: 5 standard errors of the
    mean of 4096 weights, + 1e-4."""
    import drjit as dr

    from tests.groundtruth.common import horizon_fraction

    paper_bsdf.register(mi)
    material = Material("blend", kd=(0.8, 0.5, 0.2), exponent=exponent, f0=0.04)
    bsdf = mi.load_dict(paper_bsdf.material_dict(material))
    n = 4096
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    sin_i = math.sqrt(max(0.0, 1 - cos_i * cos_i))
    si.wi = mi.Vector3f(sin_i, 0.0, cos_i)
    sampler = np.random.default_rng(3).random((3, n))
    ctx = mi.BSDFContext()
    bs, weight = bsdf.sample(ctx, si, mi.Float(sampler[0]), mi.Point2f(sampler[1], sampler[2]))
    value, pdf = bsdf.eval(ctx, si, bs.wo), bsdf.pdf(ctx, si, bs.wo)
    weight, value, pdf, bs_pdf = np.array(weight).T, np.array(value).T, np.array(pdf), np.array(bs.pdf)
    assert np.isfinite(weight).all() and (weight >= 0).all()
    np.testing.assert_allclose(bs_pdf, pdf, rtol=1e-6)
    ok = pdf > 0
    np.testing.assert_allclose(weight[ok], value[ok] / pdf[ok, None], rtol=1e-5)
    assert (weight[~ok] == 0).all()
    if cos_i <= 0:
        return  # grazing or behind the shading normal: the back-face rule, not this test's
    F = 0.04 + 0.96 * (1 - cos_i) ** 5
    frac = float(horizon_fraction(np.array(cos_i), exponent))
    albedo = (1 - F) * np.asarray(material.kd) + F * 1.0 * frac
    se = weight.std(axis=0) / math.sqrt(n)
    assert np.all(np.abs(weight.mean(axis=0) - albedo) < 5 * se + 1e-4), (weight.mean(axis=0), albedo, se)
