"""The glTF 2.0 metallic-roughness material as a Mitsuba 3 BSDF plugin, `iblcheck_gltf_pbr`.

The reflectance is the glTF 2.0 specification's Appendix B, "BRDF Implementation" (material type "pbr",
scenes/model/materials.py), evaluated exactly, with nothing added (no multiple-scattering compensation,
no energy-conserving diffuse coupling: the specification's "Discussion" names both as improvements an
implementation may make, and a reference for the real-time side must not make them).

Section "Specular BRDF":

    MicrofacetBRDF = G D / (4 |N.L| |N.V|) = nu D
    D  = alpha^2 chi+(N.H) / (pi ((N.H)^2 (alpha^2 - 1) + 1)^2)          (Trowbridge-Reitz / GGX)

with, in the specification's current text (its 2026 revision, made to match the Khronos glTF Sample
Viewer), "the height-correlated form of the Smith joint masking-shadowing function" (Heitz 2014, eq. 99):

    nu = chi+(H.L) chi+(H.V) / (2 (|N.V| sqrt(alpha^2 + (1 - alpha^2)(N.L)^2)
                                   + |N.L| sqrt(alpha^2 + (1 - alpha^2)(N.V)^2)))

The ratified 2.0.1 text had "the separable form" instead (Smith's G1(L) G1(V), which is also what
Mitsuba's `roughconductor` uses):

    nu = chi+(H.L) / (|N.L| + sqrt(alpha^2 + (1 - alpha^2)(N.L)^2))
       * chi+(H.V) / (|N.V| + sqrt(alpha^2 + (1 - alpha^2)(N.V)^2))

Both are here (`smith` = "height_correlated" or "separable"); SMITH is the one `material_dict` uses and
must be the one the real-time shader uses. The separable form is never the larger: with Smith's
G1 = 1 / (1 + Lambda), (1 + Lambda(L))(1 + Lambda(V)) >= 1 + Lambda(L) + Lambda(V).

Section "Diffuse BRDF": diffuse_brdf(color) = color / pi. Section "Fresnel" (Schlick 1994):
F = f0 + (1 - f0)(1 - |V.H|)^5; conductor_fresnel(f0, bsdf) = bsdf F; fresnel_mix(ior, base, layer)
= mix(base, layer, F) with f0 = ((1 - ior) / (1 + ior))^2. Section "Metal BRDF and Dielectric BRDF":

    metal_brdf      = specular_brdf(roughness^2) * (baseColor + (1 - baseColor)(1 - |V.H|)^5)
    dielectric_brdf = mix(diffuse_brdf(baseColor), specular_brdf(roughness^2), 0.04 + 0.96 (1 - |V.H|)^5)
    material        = mix(dielectric_brdf, metal_brdf, metallic)

alpha = roughness^2 is clamped below at materials.PBR_MIN_ALPHA (materials.pbr_alpha): the specification's
note on zero roughness ("alpha should be clamped to a small positive value"), Filament's minimum.

Local frame: the shading normal is +Z, `si.wi` = V (towards the viewer), `wo` = L (towards the light).
One-sided, as the paper's materials (scenes/model/materials.py): the value and the pdf are 0 for
cos_i = V.z <= 0 or cos_o = L.z <= 0; `material.two_sided` wraps the plugin in Mitsuba's `twosided`.
With both above the surface H = normalize(V + L) has H.V = H.L > 0 and N.H > 0, so the chi+ factors are 1.

Precision (float32): D is written with tan^2(theta_h) = (hx^2 + hy^2) / hz^2 of the unnormalised
h = V + L: (N.H)^2 (alpha^2 - 1) + 1 = (N.H)^2 (alpha^2 + tan^2 theta_h), so

    D = alpha^2 |h|^4 / (pi (alpha^2 hz^2 + hx^2 + hy^2)^2),

which resolves a lobe of alpha = 2e-3 (1 - (N.H)^2 from a float32 N.H cannot: its error, 1e-7, is
2.5% of alpha^2 = 4e-6).

Sampling: a mixture of cosine-weighted hemisphere sampling (the diffuse lobe) and GGX visible-normal
sampling (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4)) reflected about the
sampled normal. The selection probability of the specular strategy is its share of the lobes' weights at
the view direction, F(N.V) evaluated as Schlick at N.V in place of V.H:

    w_diffuse  = (1 - metallic)(1 - F_d(N.V)) mean(baseColor)
    w_specular = (1 - metallic) F_d(N.V) + metallic mean(baseColor + (1 - baseColor)(1 - N.V)^5)

(both strategies cover the whole upper hemisphere, so any positive choice is unbiased; 1 when both are 0).
The visible-normal density of h is D_V(h) = G1(V) max(V.H, 0) D(h) / N.V with Smith's
G1(V) = 2 N.V / (N.V + sqrt(alpha^2 + (1 - alpha^2)(N.V)^2)); the reflection's Jacobian 1 / (4 V.H) gives

    pdf_specular(L) = D_V(h) / (4 V.H) = D(h) / (2 (N.V + sqrt(alpha^2 + (1 - alpha^2)(N.V)^2))),

finite at grazing views. Samples that land below the horizon get weight 0 while their density still
counts (the pdf is that of the sampler, not renormalised over the upper hemisphere), as Mitsuba's own
microfacet BSDFs do.
"""

from __future__ import annotations

import math

from groundtruth.pathtracer.two_lobe_bsdf import make_base
from scenes.model import materials

PLUGIN_NAME = "iblcheck_gltf_pbr"
#: bump when the plugin's math or sampling changes: it is part of the reference cache key of scenes
#: with a "pbr" material (groundtruth/pathtracer/reference_cache.py)
PLUGIN_VERSION = 1
#: the Smith masking-shadowing form `material_dict` asks for (see the module docstring)
SMITH = "height_correlated"
SMITH_FORMS = ("height_correlated", "separable")
#: the dielectric's normal-incidence reflectance: ior 1.5, f0 = ((1 - 1.5) / (1 + 1.5))^2
DIELECTRIC_F0 = materials.PBR_DIELECTRIC_F0

_registered = False


def register(mi) -> None:
    """Register `iblcheck_gltf_pbr` with Mitsuba (idempotent per process and variant)."""
    global _registered
    if _registered:
        return
    mi.register_bsdf(PLUGIN_NAME, lambda props: make_class(mi)(props))
    _registered = True


def make_class(mi):
    import drjit as dr  # deferred: Mitsuba's variant (variant.py) is chosen before Dr.Jit loads

    class GltfPbrBSDF(make_base(mi, dr)):
        def __init__(self, props):
            super().__init__(props)
            rgb = [float(props.get(f"base_color_{c}", 1.0)) for c in "rgb"]
            self.base_rgb = rgb
            self.base_color = mi.Color3f(*rgb)
            self.base_mean = sum(rgb) / 3.0
            self.metallic = float(props.get("metallic", 0.0))
            self.roughness = float(props.get("roughness", 0.5))
            self.alpha = materials.pbr_alpha(self.roughness)
            self.smith = str(props.get("smith", SMITH))
            if self.smith not in SMITH_FORMS:
                raise ValueError(f"{PLUGIN_NAME}: smith = {self.smith!r}; expected one of {SMITH_FORMS}")
            checked = (("metallic", self.metallic), ("roughness", self.roughness),
                       *((f"base_color_{c}", v) for c, v in zip("rgb", rgb, strict=True)))
            for name, value in checked:
                if not 0.0 <= value <= 1.0:
                    raise ValueError(f"{PLUGIN_NAME}: {name} = {value} is outside [0, 1]")

        # -- the terms of the specification's Appendix B
        def _lambda_root(self, cos):
            """sqrt(alpha^2 + (1 - alpha^2) cos^2), the root shared by G1 and both Smith forms."""
            a2 = self.alpha * self.alpha
            return dr.sqrt(a2 + (1.0 - a2) * cos * cos)

        def _ggx_d(self, h):
            """D of the unnormalised half vector h = V + L (hz > 0):
            alpha^2 |h|^4 / (pi (alpha^2 hz^2 + hx^2 + hy^2)^2)."""
            a2 = self.alpha * self.alpha
            tangential = h.x * h.x + h.y * h.y
            norm2 = tangential + h.z * h.z
            denom = a2 * h.z * h.z + tangential
            return a2 * norm2 * norm2 / (math.pi * dr.maximum(denom * denom, 1e-36))

        def _visibility(self, cos_i, cos_o):
            """nu = G / (4 N.L N.V) of the chosen Smith form (both cosines > 0)."""
            root_i, root_o = self._lambda_root(cos_i), self._lambda_root(cos_o)
            if self.smith == "separable":
                return 1.0 / ((cos_o + root_o) * (cos_i + root_i))
            return 0.5 / dr.maximum(cos_i * root_o + cos_o * root_i, 1e-30)

        def _weights(self, ctx, cos_i):
            """(diffuse, specular) lobe weights at the view direction, each 0 when its component is off."""
            w5 = dr.power(1.0 - dr.clip(cos_i, 0.0, 1.0), 5.0)
            fresnel_d = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * w5
            w_diffuse = (1.0 - self.metallic) * (1.0 - fresnel_d) * self.base_mean
            fresnel_m = self.base_mean + (1.0 - self.base_mean) * w5
            w_specular = (1.0 - self.metallic) * fresnel_d + self.metallic * fresnel_m
            on_d = dr.select(ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 0), 1.0, 0.0)
            on_s = dr.select(ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 1), 1.0, 0.0)
            return w_diffuse * on_d, w_specular * on_s

        def _prob_specular(self, ctx, cos_i):
            w_diffuse, w_specular = self._weights(ctx, cos_i)
            total = w_diffuse + w_specular
            return dr.select(total > 0, w_specular / dr.maximum(total, 1e-30), 1.0)

        def _eval_pdf(self, ctx, si, wo, active):
            cos_i = mi.Frame3f.cos_theta(si.wi)
            cos_o = mi.Frame3f.cos_theta(wo)
            above = active & (cos_i > 0) & (cos_o > 0)  # one-sided, and the chi+ factors
            ci, co = dr.maximum(cos_i, 1e-30), dr.maximum(cos_o, 1e-30)
            h = si.wi + wo
            d = self._ggx_d(h)
            # |V.H| = V.(V + L) / |V + L|
            v_dot_h = dr.clip(dr.dot(si.wi, h) * dr.rsqrt(dr.maximum(dr.squared_norm(h), 1e-30)), 0.0, 1.0)
            w5 = dr.power(1.0 - v_dot_h, 5.0)
            specular = self._visibility(ci, co) * d
            fresnel_d = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * w5
            fresnel_m = self.base_color + (1.0 - self.base_color) * w5
            on_d = dr.select(ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 0), 1.0, 0.0)
            on_s = dr.select(ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 1), 1.0, 0.0)
            f_diffuse = (1.0 - self.metallic) * (1.0 - fresnel_d) * self.base_color / math.pi
            f_specular = ((1.0 - self.metallic) * fresnel_d + self.metallic * fresnel_m) * specular
            value = (f_diffuse * on_d + f_specular * on_s) * co

            p_s = self._prob_specular(ctx, cos_i)
            pdf_specular = d / (2.0 * (ci + self._lambda_root(ci)))
            pdf = p_s * pdf_specular + (1.0 - p_s) * co / math.pi
            return dr.select(above, value, 0.0), dr.select(above, pdf, 0.0)

        def _sample_visible_normal(self, wi, u):
            """Heitz 2018, listing 1: a normal of D_V(., wi) from u in [0, 1)^2 (wi.z > 0)."""
            a = self.alpha
            # the view direction in the hemisphere configuration (the stretched, alpha = 1 space)
            vh = dr.normalize(mi.Vector3f(a * wi.x, a * wi.y, dr.maximum(wi.z, 1e-30)))
            lensq = vh.x * vh.x + vh.y * vh.y
            inv = dr.rsqrt(dr.maximum(lensq, 1e-30))
            t1 = dr.select(lensq > 0, mi.Vector3f(-vh.y * inv, vh.x * inv, 0.0), mi.Vector3f(1.0, 0.0, 0.0))
            t2 = dr.cross(vh, t1)
            # a uniform point of the unit disk, its second coordinate warped onto the projected hemisphere
            r = dr.sqrt(u.x)
            s, c = dr.sincos(2.0 * math.pi * u.y)
            p1, p2 = r * c, r * s
            blend = 0.5 * (1.0 + vh.z)
            p2 = (1.0 - blend) * dr.safe_sqrt(1.0 - p1 * p1) + blend * p2
            nh = p1 * t1 + p2 * t2 + dr.safe_sqrt(1.0 - p1 * p1 - p2 * p2) * vh
            # back to the ellipsoid configuration
            return dr.normalize(mi.Vector3f(a * nh.x, a * nh.y, dr.maximum(nh.z, 1e-30)))

        def _sample_direction(self, ctx, si, sample1, sample2):
            cos_i = mi.Frame3f.cos_theta(si.wi)
            pick_specular = sample1 < self._prob_specular(ctx, cos_i)
            wo_diffuse = mi.warp.square_to_cosine_hemisphere(sample2)
            m = self._sample_visible_normal(si.wi, sample2)
            wo_specular = 2.0 * dr.dot(si.wi, m) * m - si.wi  # the mirror of V about m
            wo = dr.select(pick_specular, wo_specular, wo_diffuse)
            return wo, pick_specular

        def to_string(self):
            return (f"GltfPbrBSDF[base_color={self.base_rgb}, metallic={self.metallic}, "
                    f"roughness={self.roughness}, alpha={self.alpha}, smith={self.smith}]")

    return GltfPbrBSDF


def material_dict(material, smith: str = SMITH) -> dict:
    """The `load_dict` entry of a scenes.Material of type "pbr" for the `iblcheck_gltf_pbr` plugin."""
    if material.type != "pbr":
        raise ValueError(f"{PLUGIN_NAME} renders materials of type 'pbr', not {material.type!r}")
    d = {"type": PLUGIN_NAME, "metallic": float(material.metallic), "roughness": float(material.roughness),
         "smith": smith}
    for c, value in zip("rgb", material.base_color, strict=True):
        d[f"base_color_{c}"] = float(value)
    return d
