"""scenes.Scene -> a Mitsuba 3 scene (docs/contract.md section 2: both renderers must agree exactly).

- Environment: the `envmap` emitter made from the very array `Environment.radiance()` returns
  (scale already applied), turned about +Y by `to_world = rotate([0, 1, 0], rotation_deg)`.
  With `reference.lighting = "light_array"`: instead, the real-time side's light array
  (scenes/environment/light_array.py, the same placement and powers) as N `directional` emitters, light i with
  `irradiance` = its power and `direction` = -l_i (Mitsuba's is the direction the light travels),
  picked in proportion to its power (`sampling_weight`).
- Camera: `perspective` with `fov_axis = 'y'` and `Camera.mitsuba_to_world()` (Mitsuba's film +X
  points left, see camera.py); `hdrfilm` RGBA with a box filter (the default gaussian blurs).
- Objects: `mi.Mesh` built from the same float32 vertices, normals and indices the real-time side
  draws (never Mitsuba's analytic sphere, whose silhouette differs from a mesh).
- Materials: `reference.model = "paper"` uses the material's exact BSDF: the `iblcheck_paper` plugin
  (the paper's reflectance) and, for a glTF "pbr" material, the `iblcheck_gltf_pbr` plugin (glTF 2.0's
  Appendix B); `"physical"` maps to Mitsuba's own `diffuse`, `roughconductor`, `roughplastic` or, for
  "pbr", `principled` (see `physical_material`). All are one-sided (black seen from behind the shading
  normal); `material.two_sided` wraps them in `twosided`.
- Integrator (docs/contract.md section 4): no occlusion -> direct lighting only (`path` with max_depth 2:
  emitter sampling and BSDF sampling with MIS); occlusion -> full path tracing with
  `reference.max_depth`; an explicit `reference.integrator` overrides.
"""

from __future__ import annotations

import math

import numpy as np

from groundtruth.pathtracer import gltf_pbr_bsdf, paper_bsdf
from scenes.environment import light_array
from scenes.environment.directions import rotation_y
from scenes.model import materials


def integrator_kind(scene) -> str:
    """"direct" or "path", from `reference.integrator` or the scene's effects."""
    chosen = scene.reference.integrator
    if chosen != "auto":
        return chosen
    return "path" if "occlusion" in scene.effects else "direct"


def unsimulated_effects(scene, integrator: str | None = None) -> list[str]:
    """The effects `scene` calls for that its reference leaves out: interreflection with the `direct`
    integrator (max_depth 2: light reaches the camera after one bounce, from the environment or from
    the light array alike; shadows, i.e. occlusion, are simulated). `integrator`: the one that rendered
    the reference (its meta), or `integrator_kind(scene)`."""
    kind = integrator or integrator_kind(scene)
    return ["interreflection"] if kind == "direct" and "interreflection" in scene.effects else []


def integrator_dict(scene, hide_emitters: bool = False) -> dict:
    depth = 2 if integrator_kind(scene) == "direct" else scene.reference.max_depth
    return {"type": "path", "max_depth": depth, "hide_emitters": hide_emitters}


def f0_to_ior(f0: float) -> float:
    """Index of refraction with normal-incidence reflectance f0 = ((n - 1) / (n + 1))^2."""
    s = math.sqrt(min(max(f0, 1e-6), 0.999))
    return (1.0 + s) / (1.0 - s)


def phong_to_alpha(exponent: float) -> float:
    """The usual Phong exponent -> microfacet roughness map alpha = sqrt(2 / (N + 2)) (Walter et al. 2007)."""
    return math.sqrt(2.0 / (exponent + 2.0))


def physical_material(material) -> dict:
    """Mitsuba's own physically based stand-in for a paper material.

    diffuse -> `diffuse`; phong -> `roughconductor` with a perfectly reflecting ks tint (a
    Fresnel-free GGX lobe, as the paper's phong has F = 1); blend -> `roughplastic` (GGX coat
    over a diffuse base) with alpha from the exponent and `int_ior` from f0; pbr -> `principled`
    (`principled_material`).
    """
    if material.type == "pbr":
        return principled_material(material)
    fresnel = materials.of(material).fresnel
    if fresnel == "zero":
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(material.kd)}}
    alpha = phong_to_alpha(material.exponent)
    if fresnel == "one":
        return {"type": "roughconductor", "distribution": "ggx", "alpha": alpha, "material": "none",
                "specular_reflectance": {"type": "rgb", "value": list(material.ks)}}
    return {"type": "roughplastic", "distribution": "ggx", "alpha": alpha, "int_ior": f0_to_ior(material.f0),
            "ext_ior": 1.0, "nonlinear": False,
            "diffuse_reflectance": {"type": "rgb", "value": list(material.kd)},
            "specular_reflectance": {"type": "rgb", "value": list(material.ks)}}


def principled_material(material) -> dict:
    """Mitsuba's `principled` for a glTF "pbr" material: the same base_color, metallic and roughness, and
    `specular = 0.5` (Disney's F0 = 0.08 specular = 0.04, glTF's dielectric F0, ior 1.5).

    This is Disney's model (Burley 2012, 2015), not glTF's: its diffuse lobe has Disney's retro-reflection
    and Fresnel-shaped grazing terms instead of Lambert times (1 - F(v.h)), the dielectric's specular
    takes the full dielectric Fresnel instead of Schlick's, and its masking is Smith's separable form. A
    "physical" reference of a pbr material therefore measures a technique against another BRDF; the exact
    one is `reference.model = "paper"`. roughness is clamped below at sqrt(PBR_MIN_ALPHA) so that
    roughness 0 is the same sharpest lobe as glTF's (alpha = roughness^2 in both).
    """
    return {"type": "principled", "base_color": {"type": "rgb", "value": [float(c) for c in material.base_color]},
            "metallic": float(material.metallic),
            "roughness": max(float(material.roughness), materials.PBR_MIN_ALPHA ** 0.5),
            "specular": 0.5, "spec_tint": 0.0, "sheen": 0.0, "clearcoat": 0.0, "spec_trans": 0.0,
            "anisotropic": 0.0}


def exact_material(material) -> dict:
    """The material's own BSDF: glTF's for a "pbr" material, the paper's for the paper's types."""
    if material.type == "pbr":
        return gltf_pbr_bsdf.material_dict(material)
    return paper_bsdf.material_dict(material)


def bsdf_dict(scene, material) -> dict:
    """The material's BSDF: one-sided, or wrapped in Mitsuba's `twosided` for `material.two_sided`
    (scenes/model/materials.py: the real-time shader flips the normal there). `reference.model = "paper"`
    means the material's exact BSDF (`exact_material`), `"physical"` Mitsuba's stand-in."""
    inner = exact_material(material) if scene.reference.model == "paper" else physical_material(material)
    return {"type": "twosided", "bsdf": inner} if material.two_sided else inner


def make_mesh(mi, name: str, mesh, bsdf) -> object:
    """An `mi.Mesh` holding exactly the scenes.Mesh arrays (float32 positions and normals)."""
    props = mi.Properties()
    props["bsdf"] = bsdf
    out = mi.Mesh(name, len(mesh.positions), len(mesh.indices), has_vertex_normals=True, props=props)
    params = mi.traverse(out)
    # flat, interleaved (x0, y0, z0, x1, ...) buffers of the parameter's own type (JIT or scalar)
    for key, arr in (("vertex_positions", mesh.positions), ("vertex_normals", mesh.normals),
                     ("faces", mesh.indices.astype(np.uint32))):
        params[key] = type(params[key])(np.ascontiguousarray(arr).ravel())
    params.update()
    return out


def sensor_dict(mi, scene, spp: int, seed: int) -> dict:
    cam = scene.camera
    return {
        "type": "perspective",
        "fov_axis": "y",
        "fov": float(cam.fov_deg),
        "near_clip": 1e-3,
        "far_clip": 1e6,
        "to_world": mi.ScalarTransform4f(cam.mitsuba_to_world().astype(np.float64).tolist()),
        "sampler": {"type": "independent", "sample_count": int(spp), "seed": int(seed)},
        "film": {"type": "hdrfilm", "width": int(cam.width), "height": int(cam.height),
                 "pixel_format": "rgba", "rfilter": {"type": "box"}, "sample_border": False},
    }


def emitter_dict(mi, scene, env: np.ndarray) -> dict:
    return {"type": "envmap", "bitmap": mi.Bitmap(np.array(env, dtype=np.float32, order="C")),  # a writable copy
            "to_world": mi.ScalarTransform4f().rotate([0, 1, 0], float(scene.environment.rotation_deg))}


def light_array_emitters(scene, env: np.ndarray) -> dict:
    """The scene's light array as Mitsuba `directional` emitters (world directions: the map's rotation)."""
    params = scene.realtime.lights
    array = light_array.make(env, params.placement, params.count)
    world = array.directions @ rotation_y(scene.environment.rotation_deg).T
    # emitters are picked in proportion to their power (Mitsuba's sampling_weight), not uniformly: with
    # hundreds of lights of very different power, uniform picking is the noise of the reference
    return {f"light{i}": {"type": "directional", "direction": (-d).tolist(),
                          "irradiance": {"type": "rgb", "value": p.tolist()},
                          "sampling_weight": float(max(p.mean(), 1e-12 * array.powers.mean()))}
            for i, (d, p) in enumerate(zip(world, array.powers, strict=True)) if p.max() > 0.0}


def build(mi, scene, env: np.ndarray, spp: int, seed: int, hide_emitters: bool = False):
    """The loaded `mi.Scene` (the reference when hide_emitters is False, the coverage pass when True)."""
    paper_bsdf.register(mi)
    gltf_pbr_bsdf.register(mi)
    tree = {"type": "scene", "integrator": integrator_dict(scene, hide_emitters),
            "sensor": sensor_dict(mi, scene, spp, seed)}
    if scene.reference.lighting == "light_array":
        tree.update(light_array_emitters(scene, env))
    else:
        tree["env"] = emitter_dict(mi, scene, env)
    for i, obj in enumerate(scene.objects):
        bsdf = mi.load_dict(bsdf_dict(scene, obj.material))
        tree[f"object{i}"] = make_mesh(mi, f"object{i}", obj.mesh, bsdf)
    return mi.load_dict(tree)
