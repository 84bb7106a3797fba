"""What iblcheck's two Mitsuba 3 BSDF plugins share (paper_bsdf.py, gltf_pbr_bsdf.py): a one-sided BSDF of a
diffuse lobe (component 0) and a glossy lobe (component 1), sampled as a mixture of the two.

A plugin subclasses the class `make_base` returns and writes its own lobe math:
- `_eval_pdf(ctx, si, wo, active) -> (value, pdf)`: the BSDF value times cos(theta_o) and the mixture's
  density of `wo`, both 0 where the plugin's lobes are off or below the horizon;
- `_sample_direction(ctx, si, sample1, sample2) -> (wo, glossy)`: a direction drawn from the mixture and
  whether the glossy lobe drew it.
The base turns them into Mitsuba's interface: `eval`, `pdf`, `eval_pdf` and `sample`, whose weight is
value / pdf of the mixture (a multiple-importance estimate over the two lobes), 0 where the density is 0.
"""

from __future__ import annotations


def make_base(mi, dr):
    """The shared base class for Mitsuba's active variant (`mi` and `dr` after the variant is set)."""

    class TwoLobeBSDF(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            diffuse = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
            glossy = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
            self.m_components = [diffuse, glossy]
            self.m_flags = diffuse | glossy

        def _eval_pdf(self, ctx, si, wo, active):
            raise NotImplementedError

        def _sample_direction(self, ctx, si, sample1, sample2):
            raise NotImplementedError

        def eval(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)[1]

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wo, glossy = self._sample_direction(ctx, si, sample1, sample2)
            value, pdf = self._eval_pdf(ctx, si, wo, active)
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = wo
            bs.pdf = pdf
            bs.eta = 1.0
            bs.sampled_type = dr.select(glossy, mi.UInt32(+mi.BSDFFlags.GlossyReflection),
                                        mi.UInt32(+mi.BSDFFlags.DiffuseReflection))
            bs.sampled_component = dr.select(glossy, mi.UInt32(1), mi.UInt32(0))
            ok = active & (pdf > 0)
            weight = dr.select(ok, value / dr.maximum(pdf, 1e-30), 0.0)
            return bs, weight

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

    return TwoLobeBSDF
