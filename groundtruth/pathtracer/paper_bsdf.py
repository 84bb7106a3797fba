"""The paper's reflectance as a Mitsuba 3 BSDF plugin, `iblcheck_paper` (docs/contract.md section 3).

Local frame: the shading normal is +Z, `si.wi` points towards the viewer (v), `wo` towards the
light (l). Per unit projected solid angle the BSDF value times cos(theta_o) is

    (1 - F) kd / pi cos_o + F ks (N + 1) / (2 pi) max(r . wo, 0)^N,   0 for cos_o <= 0,

with r = (-wi.x, -wi.y, wi.z) the mirror of v, F = f0 + (1 - f0)(1 - clamp(wi.z, 0, 1))^5 for
`blend`, F = 0 for `diffuse`, F = 1 for `phong` (the same clamp as the real-time shader).

One-sided (scenes/model/materials.py): the value is 0 for cos_i = wi.z <= 0, a viewer behind the
shading normal (the back of a surface, or a silhouette where the interpolated normal has turned away),
as Mitsuba's own one-sided BSDFs are and as the real-time shader draws it. `material.two_sided` wraps
this plugin in Mitsuba's `twosided`, which flips wi and wo there instead (groundtruth/pathtracer/mitsuba_scene.py).

Sampling mixes cosine-weighted hemisphere sampling and sampling of the Phong lobe about r
(cos alpha = xi^(1 / (N + 1))) with probabilities proportional to the two lobes' weights
(1 - F) mean(kd) and F mean(ks); the pdf is the matching mixture. Lobe samples that fall below
the horizon are returned with weight 0 (their density still counts in the pdf), as Mitsuba's
own BSDFs do.

Precision: for exponents up to 1e6 the lobe lives within ~1e-3 rad of r, where float32 `r . wo`
cannot resolve it, so 1 - r.wo is computed as |r - wo|^2 / 2 and 1 - cos alpha with expm1.
"""

from __future__ import annotations

import math

from groundtruth.pathtracer.two_lobe_bsdf import make_base
from scenes.model import materials

PLUGIN_NAME = "iblcheck_paper"
#: bump when the plugin's math or sampling changes: it is part of the reference cache key
#: (4: zero for a viewer behind the shading normal)
PLUGIN_VERSION = 4

_registered = False


def _expm1(dr, x):
    """exp(x) - 1 without cancellation for small |x| (drjit has no expm1)."""
    small = dr.abs(x) < 1e-3
    series = x * (1.0 + x * (0.5 + x * (1.0 / 6.0)))
    return dr.select(small, series, dr.exp(x) - 1.0)


def _log1p_neg(dr, d):
    """log(1 - d) for d in [0, 1) without cancellation for small d."""
    small = d < 1e-3
    series = -d * (1.0 + d * (0.5 + d * (1.0 / 3.0)))
    return dr.select(small, series, dr.log(dr.maximum(1.0 - d, 1e-30)))


def register(mi) -> None:
    """Register `iblcheck_paper` with Mitsuba (idempotent per process and variant)."""
    global _registered
    if _registered:
        return
    mi.register_bsdf(PLUGIN_NAME, lambda props: make_class(mi)(props))
    _registered = True


def make_class(mi):
    import drjit as dr  # deferred: Mitsuba's variant (variant.py) is chosen before Dr.Jit loads

    class PaperBSDF(make_base(mi, dr)):
        def __init__(self, props):
            super().__init__(props)
            self.code = int(props.get("material", materials.TYPES["blend"].code))
            self.fresnel_kind = {t.code: t.fresnel for t in materials.TYPES.values()}[self.code]
            self.kd = mi.Color3f(props.get("kd_r", 0.8), props.get("kd_g", 0.8), props.get("kd_b", 0.8))
            self.ks = mi.Color3f(props.get("ks_r", 1.0), props.get("ks_g", 1.0), props.get("ks_b", 1.0))
            self.exponent = float(props.get("exponent", 100.0))
            self.f0 = float(props.get("f0", 0.04))
            self.kd_mean = sum(props.get(f"kd_{c}", 0.8) for c in "rgb") / 3.0
            self.ks_mean = sum(props.get(f"ks_{c}", 1.0) for c in "rgb") / 3.0

        # -- the two lobes' weights (1 - F, F) and the mixture's selection probability
        def _fresnel(self, cos_i):
            if self.fresnel_kind == "zero":
                return mi.Float(0.0)
            if self.fresnel_kind == "one":
                return mi.Float(1.0)
            c = dr.clip(cos_i, 0.0, 1.0)
            return self.f0 + (1.0 - self.f0) * dr.power(1.0 - c, 5.0)

        def _prob_diffuse(self, ctx, F):
            wd = (1.0 - F) * self.kd_mean * dr.select(ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 0), 1.0, 0.0)
            wg = F * self.ks_mean * dr.select(ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 1), 1.0, 0.0)
            total = wd + wg
            return dr.select(total > 0, wd / dr.maximum(total, 1e-30), 1.0)

        @staticmethod
        def _mirror(wi):
            return mi.Vector3f(-wi.x, -wi.y, wi.z)

        def _lobe(self, r, wo):
            """(N + 1) / (2 pi) max(r . wo, 0)^N from 1 - r.wo = |r - wo|^2 / 2."""
            d = 0.5 * dr.squared_norm(r - wo)
            if self.exponent == 0:
                powed = dr.select(d <= 1.0, 1.0, 0.0)
            else:
                powed = dr.select(d < 1.0, dr.exp(self.exponent * _log1p_neg(dr, dr.minimum(d, 1.0))), 0.0)
            return (self.exponent + 1.0) / (2.0 * math.pi) * powed

        def _eval_pdf(self, ctx, si, wo, active):
            cos_o = mi.Frame3f.cos_theta(wo)
            cos_i = mi.Frame3f.cos_theta(si.wi)
            F = self._fresnel(cos_i)
            lobe = self._lobe(self._mirror(si.wi), wo)
            cos_pdf = dr.maximum(cos_o, 0.0) / math.pi
            value = (1.0 - F) * self.kd * cos_pdf * dr.select(ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 0),
                                                                1.0, 0.0)
            value += F * self.ks * lobe * dr.select(ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 1), 1.0, 0.0)
            p_d = self._prob_diffuse(ctx, F)
            pdf = p_d * cos_pdf + (1.0 - p_d) * lobe
            above = active & (cos_o > 0) & (cos_i > 0)  # one-sided: nothing seen from behind the normal
            return dr.select(above, value, 0.0), dr.select(above, pdf, 0.0)

        def _sample_direction(self, ctx, si, sample1, sample2):
            F = self._fresnel(mi.Frame3f.cos_theta(si.wi))
            # (a comparison, not ~: in a scalar variant the mask is a Python bool, and ~True is -2)
            pick_glossy = sample1 >= self._prob_diffuse(ctx, F)
            wo_diffuse = mi.warp.square_to_cosine_hemisphere(sample2)
            # lobe about r: 1 - cos(alpha) = -expm1(log(xi) / (N + 1)), phi uniform
            xi = dr.maximum(sample2.x, 1e-30)
            one_minus = -_expm1(dr, dr.log(xi) / (self.exponent + 1.0))
            one_minus = dr.clip(one_minus, 0.0, 1.0)
            sin_alpha = dr.safe_sqrt(one_minus * (2.0 - one_minus))
            phi = 2.0 * math.pi * sample2.y
            s, c = dr.sincos(phi)
            local = mi.Vector3f(sin_alpha * c, sin_alpha * s, 1.0 - one_minus)
            wo_glossy = mi.Frame3f(self._mirror(si.wi)).to_world(local)
            wo = dr.select(pick_glossy, wo_glossy, wo_diffuse)
            return wo, pick_glossy

        def to_string(self):
            return (f"PaperBSDF[material={self.code}, exponent={self.exponent}, f0={self.f0}, "
                    f"kd_mean={self.kd_mean}, ks_mean={self.ks_mean}]")

    return PaperBSDF


def material_dict(material) -> dict:
    """The `load_dict` entry of a scenes.Material for the `iblcheck_paper` plugin."""
    kind = materials.of(material)
    d = {"type": PLUGIN_NAME, "material": kind.code, "exponent": float(material.exponent), "f0": float(material.f0)}
    kd = material.kd if kind.diffuse_lobe else materials.BLACK
    ks = material.ks if kind.glossy_lobe else materials.BLACK
    for name, rgb in (("kd", kd), ("ks", ks)):
        for c, value in zip("rgb", rgb, strict=True):
            d[f"{name}_{c}"] = float(value)
    return d
