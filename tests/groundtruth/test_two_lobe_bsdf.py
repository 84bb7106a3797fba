"""What both BSDF plugins inherit from two_lobe_bsdf.py: a sample names the lobe that drew it (component 0 the
diffuse lobe, 1 the glossy one; its type to match), and the glossy lobe draws its share of the mixture. Each
material here has a sharp glossy lobe, so a glossy sample lies within a few degrees of the mirror direction,
where a cosine-distributed diffuse sample almost never falls (a cap of 3 degrees: (1 - cos^2 3) < 0.3 %)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from groundtruth.pathtracer import gltf_pbr_bsdf, paper_bsdf
from scenes.model.scene import Material

pytestmark = pytest.mark.mitsuba

COS_I = 0.8
N = 8192


def paper_case():
    # blend: F = Schlick at cos_i, lobe weights (1 - F) mean(kd) and F mean(ks)
    m = Material("blend", kd=(0.6, 0.6, 0.6), ks=(1.0, 1.0, 1.0), exponent=1e4, f0=0.3)
    F = 0.3 + 0.7 * (1 - COS_I) ** 5
    return paper_bsdf, paper_bsdf.material_dict(m), F * 1.0 / ((1 - F) * 0.6 + F * 1.0)


def pbr_case():
    # metallic 0.5: diffuse (1 - m)(1 - F_d) base, specular (1 - m) F_d + m F_m at the view direction
    m = Material("pbr", base_color=(0.5, 0.5, 0.5), metallic=0.5, roughness=0.05)
    w5 = (1 - COS_I) ** 5
    fd = 0.04 + 0.96 * w5
    fm = 0.5 + 0.5 * w5
    wd, ws = 0.5 * (1 - fd) * 0.5, 0.5 * fd + 0.5 * fm
    return gltf_pbr_bsdf, gltf_pbr_bsdf.material_dict(m), ws / (wd + ws)


@pytest.mark.parametrize("case", [paper_case, pbr_case], ids=["paper", "gltf_pbr"])
def test_a_sample_names_the_lobe_that_drew_it(mi, case):
    import drjit as dr

    module, d, p_glossy = case()
    module.register(mi)
    bsdf = mi.load_dict(d)
    si = dr.zeros(mi.SurfaceInteraction3f, N)
    si.wi = mi.Vector3f(math.sqrt(1 - COS_I ** 2), 0.0, COS_I)
    u = np.random.default_rng(7).random((3, N))
    bs, _ = bsdf.sample(mi.BSDFContext(), si, mi.Float(u[0]), mi.Point2f(u[1], u[2]))
    wo = np.array(bs.wo).T
    component = np.array(bs.sampled_component)
    glossy_type = (np.array(bs.sampled_type) & int(mi.BSDFFlags.GlossyReflection)) != 0
    diffuse_type = (np.array(bs.sampled_type) & int(mi.BSDFFlags.DiffuseReflection)) != 0
    mirror = np.array([-math.sqrt(1 - COS_I ** 2), 0.0, COS_I])
    near_mirror = wo @ mirror > math.cos(math.radians(3.0))
    assert set(np.unique(component)) <= {0, 1}
    np.testing.assert_array_equal(glossy_type, component == 1)
    np.testing.assert_array_equal(diffuse_type, component == 0)
    # the glossy lobe's samples lie at the mirror direction; the diffuse lobe's almost never do
    assert near_mirror[component == 1].mean() > 0.97
    assert near_mirror[component == 0].mean() < 0.01
    # (a plugin that returns its diffuse pick as the glossy one fails here: tried by mutating paper_bsdf.py)
    # its share of the mixture: binomial, 5 standard errors
    se = math.sqrt(p_glossy * (1 - p_glossy) / N)
    assert abs((component == 1).mean() - p_glossy) < 5 * se + 1e-3, ((component == 1).mean(), p_glossy)
