"""iblcheck's materials as glTF 2.0 materials, and back.

- `pbr` is glTF's own metallic-roughness model (scenes/model/materials.py): exported exactly as core
  `pbrMetallicRoughness` (baseColorFactor [r, g, b, 1], metallicFactor, roughnessFactor), doubleSided =
  two_sided.
- `diffuse` (kd / pi): base colour kd, metallic 0, roughness 1 and KHR_materials_specular with
  specularFactor 0. That extension scales the dielectric's Fresnel term by specularFactor and weights the
  diffuse lobe by 1 - specularFactor max(F), so specularFactor 0 leaves exactly Lambert's kd / pi. An
  engine without the extension draws glTF's dielectric (F0 = 0.04, roughness 1) instead.
- `phong` and `blend` (the paper's lobe ks (N + 1) / (2 pi) max(r.l, 0)^N about the mirror direction r)
  have no glTF equivalent: refused, unless `nearest`, which exports the nearest GGX material:
  the lobe about r with exponent N is, near its peak, a half-vector lobe of exponent 4N (the angle from
  r is twice the angle from n to h), and Walter et al. 2007 (eq. 30) give the Beckmann/GGX width of a
  half-vector exponent N_h as alpha^2 = 2 / (N_h + 2); so alpha^2 = 2 / (4N + 2), roughness = sqrt(alpha).
  phong -> a metal of base colour ks; blend -> a dielectric of base colour kd whose KHR_materials_specular
  specularColorFactor = ks f0 / 0.04 moves its F0 to ks f0.
"""

from __future__ import annotations

import math

from scenes.model import materials
from scenes.storage.errors import InputError

SPECULAR = "KHR_materials_specular"


def nearest_roughness(exponent: float) -> float:
    """glTF roughness of the GGX lobe nearest the paper's Phong lobe of `exponent` (module docstring)."""
    alpha2 = 2.0 / (4.0 * float(exponent) + 2.0)
    return min(1.0, alpha2 ** 0.25)


def _pbr(name: str, base_color, metallic: float, roughness: float, two_sided: bool) -> dict:
    return {"name": name, "doubleSided": bool(two_sided),
            "pbrMetallicRoughness": {"baseColorFactor": [float(c) for c in base_color] + [1.0],
                                     "metallicFactor": float(metallic), "roughnessFactor": float(roughness)}}


def to_gltf(material, name: str, where: str, nearest: bool = False) -> tuple[dict, str, str]:
    """(the glTF material, "exact" | "nearest", the difference in one sentence or "") of a scenes.Material.

    `where` names the object in errors (`objects[3]`); phong and blend raise InputError unless `nearest`."""
    m = material
    if m.type == "pbr":
        return _pbr(name, m.base_color, m.metallic, m.roughness, m.two_sided), "exact", ""
    if m.type == "diffuse":
        out = _pbr(name, m.kd, 0.0, 1.0, m.two_sided)
        out["extensions"] = {SPECULAR: {"specularFactor": 0.0}}
        return out, "exact", ("exact where the engine supports KHR_materials_specular; without it the engine "
                              "adds glTF's dielectric specular lobe (F0 = 0.04, roughness 1)")
    if m.type not in ("phong", "blend"):
        raise InputError(f"{where}.material.type = {m.type!r}: no glTF export for this type")
    if not nearest:
        raise InputError(f"{where}.material.type = {m.type!r}: glTF 2.0 has no Phong lobe (the paper's lobe about "
                         "the mirror direction is no microfacet model); export with --nearest for the nearest GGX "
                         "material, or use type = \"pbr\"")
    roughness = nearest_roughness(m.exponent)
    alpha2 = 2.0 / (4.0 * m.exponent + 2.0)
    if m.type == "phong":
        out = _pbr(name, [min(1.0, c) for c in m.ks], 1.0, roughness, m.two_sided)
        diff = (f"phong exponent {m.exponent:g} -> GGX alpha^2 = 2 / (4N + 2) = {alpha2:.4g} (roughness "
                f"{roughness:.4g}), a metal of base colour ks: the GGX tail is longer than the Phong lobe's, Smith "
                "masking and Schlick's Fresnel (ks at normal incidence, white at grazing) replace the paper's "
                "constant ks")
        return out, "nearest", diff
    f0 = materials.PBR_DIELECTRIC_F0
    colour = [min(c * m.f0 / f0, 1.0 / f0) for c in m.ks]
    out = _pbr(name, m.kd, 0.0, roughness, m.two_sided)
    out["extensions"] = {SPECULAR: {"specularFactor": 1.0, "specularColorFactor": colour}}
    diff = (f"blend exponent {m.exponent:g} -> GGX alpha^2 = 2 / (4N + 2) = {alpha2:.4g} (roughness {roughness:.4g}), "
            f"a dielectric of base colour kd with F0 = ks f0 through KHR_materials_specular: Fresnel of v.h instead "
            "of n.v, Smith masking, and a GGX tail instead of the Phong lobe")
    return out, "nearest", diff


def from_gltf(doc: dict, index: int, where: str) -> dict:
    """The iblcheck material table ({"type": "pbr", ...}) of glTF material `index`; textured materials and
    extensions that change the BRDF are refused (InputError naming `where` and the material)."""
    mats = doc.get("materials") or []
    if index is None:  # glTF's default material: white, metallic 1, roughness 1 (3.9.6)
        return {"type": "pbr", "base_color": [1.0, 1.0, 1.0], "metallic": 1.0, "roughness": 1.0}
    if not (isinstance(index, int) and 0 <= index < len(mats)):
        raise InputError(f"{where}: material {index!r} does not exist ({len(mats)} materials)")
    mat = mats[index]
    label = f"{where}: material {index} ({mat.get('name', 'unnamed')!r})"
    pbr = mat.get("pbrMetallicRoughness", {})
    textures = [k for k in ("baseColorTexture", "metallicRoughnessTexture") if k in pbr]
    textures += [k for k in ("normalTexture", "occlusionTexture", "emissiveTexture") if k in mat]
    if textures:
        raise InputError(f"{label}: textured ({', '.join(textures)}); iblcheck's materials are uniform factors only")
    if any(c != 0 for c in mat.get("emissiveFactor", [0, 0, 0])):
        raise InputError(f"{label}: emissiveFactor {mat['emissiveFactor']}: iblcheck's materials do not emit")
    if mat.get("alphaMode", "OPAQUE") != "OPAQUE":
        raise InputError(f"{label}: alphaMode {mat['alphaMode']!r}: iblcheck draws opaque surfaces only")
    ext = dict(mat.get("extensions") or {})
    spec = ext.pop(SPECULAR, None)
    if ext:
        raise InputError(f"{label}: extensions {', '.join(sorted(ext))} change the BRDF; iblcheck has glTF's core "
                         "metallic-roughness model (and KHR_materials_specular with specularFactor 0: Lambert)")
    base = [float(c) for c in pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])]
    if base[3] != 1.0:
        raise InputError(f"{label}: baseColorFactor alpha {base[3]:g}: iblcheck draws opaque surfaces only")
    metallic = float(pbr.get("metallicFactor", 1.0))
    roughness = float(pbr.get("roughnessFactor", 1.0))
    two_sided = bool(mat.get("doubleSided", False))
    if spec is not None:
        if float(spec.get("specularFactor", 1.0)) == 0.0 and metallic == 0.0:
            return {"type": "diffuse", "kd": base[:3], "two_sided": two_sided}
        raise InputError(f"{label}: {SPECULAR} {spec}: only specularFactor 0 on a dielectric (Lambert) is read")
    if not all(math.isfinite(x) for x in (*base, metallic, roughness)):
        raise InputError(f"{label}: factors must be finite numbers")
    return {"type": "pbr", "base_color": base[:3], "metallic": metallic, "roughness": roughness,
            "two_sided": two_sided}
