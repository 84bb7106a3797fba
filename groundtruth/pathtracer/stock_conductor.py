"""Mitsuba's stock `roughconductor` for a metal glTF "pbr" material: the same metal through another
engine's microfacet code, to measure what glTF's own terms change.

`roughconductor` with `distribution = "ggx"` reflects D(m) F G / (4 cos_i cos_o) with the same GGX D
and alpha = materials.pbr_alpha(roughness) as glTF's Appendix B, but

- G is Smith's separable G1(wi) G1(wo) (Mitsuba's MicrofacetDistribution::G), where glTF's current
  text has the height-correlated form (groundtruth/pathtracer/gltf_pbr_bsdf.py); the separable form
  is never the larger, the difference growing with roughness and towards grazing;
- F: `material = "none"` makes Mitsuba's Fresnel 1, times `specular_reflectance = base_color`, where
  glTF has Schlick's base_color + (1 - base_color)(1 - |v.h|)^5.

The choice of `material = "none"` (rather than a complex IOR fitted to base_color) makes the two
Fresnel terms identical for base_color = 1, so a white metal isolates the masking-shadowing form, and
for a coloured metal the rest of the difference is Schlick's brightening towards grazing alone, with no
fitted (eta, k) in between whose own error would muddle it.
"""

from __future__ import annotations

from scenes.model import materials


def roughconductor_dict(material) -> dict:
    """The `load_dict` entry of Mitsuba's `roughconductor` for a metal (metallic = 1) "pbr" material."""
    if material.type != "pbr" or material.metallic != 1.0:
        raise ValueError(f"a stock roughconductor stands in for a metal pbr material (metallic = 1), not "
                         f"type {material.type!r} with metallic = {getattr(material, 'metallic', None)!r}: "
                         "a dielectric pbr material has a diffuse lobe no conductor has")
    return {"type": "roughconductor", "distribution": "ggx", "alpha": materials.pbr_alpha(material.roughness),
            "material": "none", "sample_visible": True,
            "specular_reflectance": {"type": "rgb", "value": [float(c) for c in material.base_color]}}
