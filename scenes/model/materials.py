"""The material types (docs/contract.md section 3, step 7): one table, read everywhere.

The paper's three types are the same reflectance with a fixed Fresnel weight F between a diffuse lobe
kd/pi cos and the normalised Phong lobe ks (N + 1)/(2 pi) max(r.l, 0)^N:

    type      F              scene keys                    lobes
    diffuse   0              kd                            diffuse
    phong     1              ks, exponent                  glossy
    blend     Schlick(f0)    kd, ks, exponent, f0          diffuse + glossy, (1 - F) / F

The fourth is the material every shipped engine uses, glTF 2.0's metallic-roughness model (the
specification's Appendix B: Lambert diffuse of base_color, a GGX lobe with alpha = roughness^2 and the
height-correlated Smith visibility, Schlick's Fresnel of v.h; dielectric F0 = 0.04, metal F0 =
base_color, the two mixed by metallic):

    pbr       gltf           base_color, metallic, roughness    diffuse (metallic < 1) + glossy

alpha is clamped below at PBR_MIN_ALPHA wherever a formula divides by it, so roughness 0 (a mirror) is
the sharpest lobe every renderer resolves, never a division by zero.

Every type also takes the keys of COMMON_FIELDS:

    two_sided   false (default): one-sided. Both renderers shade a point only when the viewer is on
                the front side of its shading normal (n . v > 0, n the interpolated vertex normal);
                elsewhere (the back of a surface, and a silhouette where the interpolated normal has
                turned away from the viewer) the point is black: the reference's BSDF is zero for
                n . v <= 0, as Mitsuba's own one-sided BSDFs are. true: the normal is flipped
                towards the viewer (the reference wraps its BSDF in Mitsuba's `twosided`).

This table drives scene validation (which keys a type accepts, the defaults of the others), the
reference cache key (only the fields a type uses: an unused kd must not split the cache), the
Mitsuba plugin and the shader (`code`, the same integer on both sides), and the quadrature's lobe
weights. A new field forgotten here is forgotten everywhere at once, not in one of seven places.
"""

from __future__ import annotations

from dataclasses import dataclass

BLACK = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class MaterialType:
    name: str
    code: int  # `material_type` in shade.frag and `material` in the iblcheck_paper plugin
    fields: tuple[str, ...]  # the Material fields this type uses (and the scene keys it accepts, with "type")
    fresnel: str  # "zero" (F = 0), "one" (F = 1), "schlick" (F = f0 + (1 - f0)(1 - n.v)^5) or "gltf" (of v.h)
    defaults: tuple[tuple[str, object], ...] = ()  # values of the fields it does not use

    @property
    def all_fields(self) -> tuple[str, ...]:
        """The type's own fields and the common ones (COMMON_FIELDS)."""
        return (*self.fields, *COMMON_FIELDS)

    @property
    def diffuse_lobe(self) -> bool:
        return self.fresnel != "one"

    @property
    def glossy_lobe(self) -> bool:
        return self.fresnel != "zero"

    @property
    def scene_keys(self) -> frozenset[str]:
        return frozenset(("type", *self.all_fields))


#: fields every material type has (see the module docstring)
COMMON_FIELDS = ("two_sided",)

#: the smallest GGX alpha = roughness^2 any renderer uses: Filament's minimum perceptual roughness 0.045
#: squared (filament/src/materials/.../common_material.fs MIN_PERCEPTUAL_ROUGHNESS), below which a float32
#: D = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2) and its sampling lose the lobe
PBR_MIN_ALPHA = 0.045 ** 2
#: the dielectric's normal-incidence reflectance in glTF's metallic-roughness model (IOR 1.5)
PBR_DIELECTRIC_F0 = 0.04


TYPES: dict[str, MaterialType] = {t.name: t for t in (
    MaterialType("diffuse", 0, ("kd",), "zero", (("ks", BLACK),)),
    MaterialType("phong", 1, ("ks", "exponent"), "one", (("kd", BLACK),)),
    MaterialType("blend", 2, ("kd", "ks", "exponent", "f0"), "schlick"),
    MaterialType("pbr", 3, ("base_color", "metallic", "roughness"), "gltf"),
)}
#: the paper's own types (their reflectance is the paper's; `pbr` is glTF's)
PAPER_TYPES = ("diffuse", "phong", "blend")
NAMES = tuple(TYPES)


def of(material) -> MaterialType:
    """The table row of a scenes.Material."""
    return TYPES[material.type]


def pbr_alpha(roughness: float) -> float:
    """GGX alpha = roughness^2 (glTF 2.0 Appendix B), never below PBR_MIN_ALPHA."""
    return max(float(roughness) ** 2, PBR_MIN_ALPHA)


def has_diffuse(material) -> bool:
    """Whether the material reflects anything through its diffuse lobe."""
    if material.type == "pbr":
        return material.metallic < 1.0 and max(material.base_color) > 0
    return of(material).diffuse_lobe and max(material.kd) > 0


def has_glossy(material) -> bool:
    """Whether the material reflects anything through its glossy lobe (a pbr material always does: even a
    black dielectric reflects F0 = 0.04 and, at grazing, all)."""
    if material.type == "pbr":
        return True
    return of(material).glossy_lobe and max(material.ks) > 0


def used_fields(material) -> dict:
    """{"type": ..., field: value} for the fields the material's type uses, the common ones included
    (cache keys, result rows)."""
    return {"type": material.type, **{k: getattr(material, k) for k in of(material).all_fields}}


def glsl_defines() -> tuple[str, ...]:
    """`MATERIAL_<NAME> <code>` for the shader's `material_type` comparisons."""
    return tuple(f"MATERIAL_{t.name.upper()} {t.code}" for t in TYPES.values())
