"""iblcheck's materials (the sidecar's `material` dicts) as Cycles shader nodes.

`choose` (pure) decides the Cycles closure and whether it is exactly iblcheck's BRDF; `build` makes the
node tree with the bpy module it is given.

- `diffuse` kd -> Diffuse BSDF of colour kd and roughness 0: Cycles' Lambert kd/pi (Oren-Nayar at 0 is
  Lambert). Exact.
- `pbr` with metallic 1 and base_color (1, 1, 1) -> Glossy BSDF, distribution GGX (single scattering, not
  MULTI_GGX), white. glTF's metal is F = base_color + (1 - base_color)(1 - v.h)^5 = 1 times V D, and Cycles'
  Glossy BSDF is the Fresnel-free GGX microfacet reflection with the height-correlated Smith G =
  1 / (1 + Lambda(v) + Lambda(l)) (Heitz 2014), which is glTF's V times 4 n.l n.v. Cycles squares its
  roughness (alpha = roughness^2, as glTF), so roughness = sqrt(max(r^2, PBR_MIN_ALPHA)) = max(r, 0.045)
  gives glTF's alpha with iblcheck's floor. Exact.
- other `pbr` -> Principled BSDF (GGX, single scattering) with base_color, metallic, roughness as above,
  IOR 1.5, Specular IOR Level 0.5 (F0 = 0.04), white specular tint, no coat, sheen, subsurface,
  transmission or emission. With metallic 1 it is exact: the Principled metal's Fresnel is the F82-tint
  model (Kutz et al. 2021, OpenPBR's metal), F = Schlick(base_color) - cos (1 - cos)^6 (1 - tint) * c, which
  with a white tint is Schlick's of base_color, glTF's metal (a copper sphere agrees with Mitsuba's glTF
  BSDF within noise, tests/engines/test_cycles.py). With metallic < 1 it is the nearest, not exact
  (`PRINCIPLED_DIFFERENCE`).
- `phong`, `blend` (the paper's lobes) -> rejected: Cycles has no normalised-Phong closure.

One-sided (iblcheck's default, `two_sided` false): black where the shading normal faces away from the
viewer (n.v < 0; n.v = 0 has measure zero) or the ray meets the back of a face: a Mix Shader between the
BSDF and a black one by max(Backfacing, [N . I < 0]) with the Geometry node's N and I (I points to the
viewer). `two_sided` true: the bare BSDF, which Cycles shades from both sides with the normal flipped
towards the viewer (Mitsuba's `twosided`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from engines.cycles.errors import SceneRejected, short_repr

#: iblcheck's smallest GGX alpha (Filament's minimum perceptual roughness 0.045, squared); the same number
#: as scenes/model/materials.py PBR_MIN_ALPHA (a test checks they agree)
PBR_MIN_ALPHA = 0.045 ** 2

PRINCIPLED_DIFFERENCE = (
    "Cycles' Principled BSDF, not glTF's BRDF: its dielectric specular takes the exact dielectric Fresnel of "
    "IOR 1.5 instead of Schlick's F0 = 0.04 + 0.96 (1 - v.h)^5, and its diffuse base is scaled by one minus the "
    "specular layer's directional albedo (energy-conserving layering) instead of glTF's (1 - F(v.h)), so it "
    "reflects less than glTF's dielectric (which gains energy at grazing angles); the metal part (F82-tint "
    "Fresnel with a white tint = Schlick's of base_color, single-scattering GGX) is glTF's")


@dataclass(frozen=True)
class Choice:
    closure: str  # "diffuse", "glossy" or "principled"
    color: tuple[float, float, float]
    metallic: float
    roughness: float  # Blender's roughness (alpha = roughness^2), the floor applied
    two_sided: bool
    exact: bool
    difference: str  # empty when exact


def _number(material: dict, key: str, where: str, lo: float = 0.0, hi: float = 1.0) -> float:
    value = material.get(key)
    if not isinstance(value, int | float) or isinstance(value, bool) or not lo <= value <= hi:
        raise SceneRejected(f"{where}.{key} = {short_repr(value)} is not a number in [{lo}, {hi}]")
    return float(value)


def _colour(material: dict, key: str, where: str) -> tuple[float, float, float]:
    value = material.get(key)
    if (not isinstance(value, list | tuple) or len(value) != 3
            or not all(isinstance(c, int | float) and not isinstance(c, bool) and 0.0 <= c <= 1e6 for c in value)):
        raise SceneRejected(f"{where}.{key} = {short_repr(value)} is not 3 non-negative numbers")
    return tuple(float(c) for c in value)


def blender_roughness(roughness: float) -> float:
    """Blender's roughness for glTF's: alpha = roughness_blender^2 = max(roughness^2, PBR_MIN_ALPHA)."""
    return math.sqrt(max(roughness * roughness, PBR_MIN_ALPHA))


def choose(material: dict, where: str) -> Choice:
    """The Cycles closure for iblcheck's material dict; `where` names it in errors ("FILE: objects[i].material")."""
    kind = material.get("type")
    two_sided = material.get("two_sided", False)
    if not isinstance(two_sided, bool):
        raise SceneRejected(f"{where}.two_sided = {short_repr(two_sided)} is not true or false")
    if kind == "diffuse":
        return Choice("diffuse", _colour(material, "kd", where), 0.0, 0.0, two_sided, True, "")
    if kind == "pbr":
        color = _colour(material, "base_color", where)
        metallic = _number(material, "metallic", where)
        roughness = blender_roughness(_number(material, "roughness", where))
        if metallic == 1.0 and color == (1.0, 1.0, 1.0):
            return Choice("glossy", color, metallic, roughness, two_sided, True, "")
        if metallic == 1.0:
            return Choice("principled", color, metallic, roughness, two_sided, True, "")
        return Choice("principled", color, metallic, roughness, two_sided, False, PRINCIPLED_DIFFERENCE)
    if kind in ("phong", "blend"):
        raise SceneRejected(f"{where}.type = {kind!r}: Cycles has no closure of the paper's normalised Phong lobe "
                            "(export with --nearest for the nearest glTF material, or use diffuse or pbr)")
    raise SceneRejected(f"{where}.type = {short_repr(kind)} is not one of diffuse, pbr")


def build(bpy, choice: Choice, name: str):
    """A bpy material of `choice` (its node tree: the BSDF, one-sided unless two_sided, to the output)."""
    mat = bpy.data.materials.new(name)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    if choice.closure == "diffuse":
        bsdf = nodes.new("ShaderNodeBsdfDiffuse")
        bsdf.inputs["Color"].default_value = (*choice.color, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.0
    elif choice.closure == "glossy":
        bsdf = nodes.new("ShaderNodeBsdfGlossy")
        bsdf.distribution = "GGX"
        bsdf.inputs["Color"].default_value = (*choice.color, 1.0)
        bsdf.inputs["Roughness"].default_value = choice.roughness
        bsdf.inputs["Anisotropy"].default_value = 0.0
    else:
        bsdf = nodes.new("ShaderNodeBsdfPrincipled")
        bsdf.distribution = "GGX"
        settings = {"Base Color": (*choice.color, 1.0), "Metallic": choice.metallic, "Roughness": choice.roughness,
                    "IOR": 1.5, "Specular IOR Level": 0.5, "Specular Tint": (1.0, 1.0, 1.0, 1.0),
                    "Diffuse Roughness": 0.0, "Subsurface Weight": 0.0, "Transmission Weight": 0.0,
                    "Coat Weight": 0.0, "Sheen Weight": 0.0, "Emission Strength": 0.0, "Anisotropic": 0.0,
                    "Thin Film Thickness": 0.0, "Alpha": 1.0}
        for key, value in settings.items():
            bsdf.inputs[key].default_value = value
    if choice.two_sided:
        links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
        return mat
    black = nodes.new("ShaderNodeBsdfDiffuse")
    black.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    geometry = nodes.new("ShaderNodeNewGeometry")
    dot = nodes.new("ShaderNodeVectorMath")
    dot.operation = "DOT_PRODUCT"
    links.new(geometry.outputs["Normal"], dot.inputs[0])
    links.new(geometry.outputs["Incoming"], dot.inputs[1])
    away = nodes.new("ShaderNodeMath")
    away.operation = "LESS_THAN"  # 1 where N . I < 0
    links.new(dot.outputs["Value"], away.inputs[0])
    away.inputs[1].default_value = 0.0
    either = nodes.new("ShaderNodeMath")
    either.operation = "MAXIMUM"
    links.new(away.outputs["Value"], either.inputs[0])
    links.new(geometry.outputs["Backfacing"], either.inputs[1])
    mix = nodes.new("ShaderNodeMixShader")
    links.new(either.outputs["Value"], mix.inputs["Fac"])
    links.new(bsdf.outputs["BSDF"], mix.inputs[1])
    links.new(black.outputs["BSDF"], mix.inputs[2])
    links.new(mix.outputs["Shader"], out.inputs["Surface"])
    return mat
