"""`iblcheck export SCENE DIR`: the scene as glTF 2.0 + a viewer-convention .hdr + a JSON sidecar.

Files in DIR (written whole or not at all, scenes/exchange/folder.py):
- scene.gltf + scene.bin: one mesh per scene object with the float32 world-space positions and normals
  both iblcheck renderers draw (`SceneObject.mesh`), uint32 indices, identity node transforms; materials
  as scenes/exchange/gltf_materials.py says; a camera node looking down its -Z with +Y up exactly as
  scenes/model/camera.py's gluLookAt view matrix (node rotation columns: right, true up, -forward).
- environment.hdr: the environment (its scale included) in the viewer convention
  (scenes/exchange/viewer_equirect.py), unrotated; the rotation goes to the sidecar.
- iblcheck-export.json: the sidecar (scenes/exchange/sidecar.py).
- with `fidelity=True`, scenario.json for glTF Render Fidelity harnesses (scenes/exchange/fidelity.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import numpy as np

from scenes.exchange import fidelity, gltf_materials, sidecar, viewer_equirect
from scenes.exchange.folder import atomic_folder
from scenes.exchange.gltf_writer import Builder, json_bytes, quaternion
from scenes.model import materials
from scenes.storage import imageio

GLTF = "scene.gltf"
BIN = "scene.bin"
ENVIRONMENT = "environment.hdr"
#: every file an export writes: an earlier export holding anything else is not replaced (folder.py)
FILES = frozenset({GLTF, BIN, ENVIRONMENT, sidecar.NAME, fidelity.SCENARIO, fidelity.LIGHTING})


@dataclass(frozen=True)
class Exported:
    folder: Path
    gltf: Path
    environment: Path
    sidecar: Path
    scenario: Path | None = None
    warnings: tuple[str, ...] = ()


def clip_planes(scene) -> tuple[float, float]:
    """(znear, zfar) enclosing every object: the bounding sphere of all vertices seen from the camera,
    zfar twice its far side, znear half its near side (at least zfar / 10^4, for depth precision)."""
    p = np.concatenate([o.mesh.positions for o in scene.objects]).astype(np.float64)
    centre = 0.5 * (p.min(axis=0) + p.max(axis=0))
    radius = float(np.linalg.norm(p - centre, axis=1).max())
    distance = float(np.linalg.norm(np.asarray(scene.camera.origin) - centre))
    zfar = 2.0 * (distance + radius) + 1e-6
    znear = max(0.5 * (distance - radius), zfar * 1e-4)
    return znear, zfar


def camera_rotation(camera) -> np.ndarray:
    """3x3 camera-node rotation: local +X -> right, +Y -> true up, +Z -> -forward (glTF 3.10.2)."""
    right, up, forward = camera.basis()
    return np.column_stack([right, up, -forward])


def build(scene, nearest: bool = False) -> tuple[Builder, list[dict], list[str]]:
    """The glTF builder, the sidecar's object list and the warning lines. Materials are checked first,
    so a refusal writes nothing."""
    b = Builder()
    objects, warns = [], []
    converted = [gltf_materials.to_gltf(o.material, f"object_{i}", f"{scene.path}: objects[{i}]", nearest)
                 for i, o in enumerate(scene.objects)]
    for i, (obj, (mat, how, diff)) in enumerate(zip(scene.objects, converted, strict=True)):
        mesh = obj.mesh
        name = f"object_{i}_{Path(obj.shape).stem}"
        b.add_mesh(name, mesh.positions, mesh.normals, mesh.indices, b.add_material(mat))
        if how == "nearest":
            warns.append(f"objects[{i}].material.type = {obj.material.type!r} exported as the nearest glTF "
                         f"material: {diff}")
        objects.append({"name": name, "mesh": i,
                        "material": {k: list(v) if isinstance(v, tuple) else v
                                     for k, v in materials.used_fields(obj.material).items()},
                        "gltf_material": i, "exported_as": how, "difference": diff})
    cam = scene.camera
    znear, zfar = clip_planes(scene)
    b.add_camera("camera", np.radians(cam.fov_deg), cam.aspect, znear, zfar, cam.origin,
                 quaternion(camera_rotation(cam)))
    return b, objects, warns


def sidecar_document(scene, objects: list[dict], camera_node: int, camera_json: dict, env_shape,
                     content_id: str | None) -> dict:
    cam = scene.camera
    h, w = env_shape[:2]
    try:
        version = metadata.version("iblcheck")
    except metadata.PackageNotFoundError:
        version = "unknown"
    return {
        "format": sidecar.FORMAT, "version": sidecar.VERSION, "scene": scene.name, "gltf": GLTF,
        "environment": {"file": ENVIRONMENT, "width": w, "height": h, "convention": viewer_equirect.CONVENTION,
                        "rotation_y_deg": float(scene.environment.rotation_deg), "rotation": sidecar.ROTATION,
                        "intensity": 1.0, "source": scene.environment.map,
                        "scale_baked_in": float(scene.environment.scale)},
        "camera": {"node": camera_node, "yfov": camera_json["yfov"], "yfov_deg": float(cam.fov_deg),
                   "aspect_ratio": camera_json["aspectRatio"], "znear": camera_json["znear"],
                   "zfar": camera_json["zfar"], "position": [float(x) for x in cam.origin],
                   "target": [float(x) for x in cam.target], "up": [float(x) for x in cam.up]},
        "image": {"width": cam.width, "height": cam.height, "pixel_center": [0.5, 0.5],
                  "row_order": "top row first", "output": sidecar.OUTPUT, "exposure": 1.0,
                  "background": "the environment"},
        "objects": objects,
        # how the path-traced reference is rendered, for a path tracer that renders the export (Cycles): samples,
        # seed and Mitsuba's max_depth (path segments; the direct integrator is max_depth 2, and with a single
        # convex object the two integrators agree)
        "reference": {"spp": scene.reference.spp, "seed": scene.reference.seed,
                      "max_depth": 2 if scene.reference.integrator == "direct" else scene.reference.max_depth},
        "iblcheck": {"version": version, "content_id": content_id},
    }


def export_scene(scene, folder: str | Path, nearest: bool = False, fidelity_scenario: bool = False,
                 content_id: str | None = None) -> Exported:
    """Write the export of `scene` into `folder` (see the module docstring)."""
    folder = Path(folder)
    if fidelity_scenario:
        fidelity.check_expressible(scene)
    b, objects, warns = build(scene, nearest)
    camera_node = len(b.nodes) - 1
    env = scene.environment.radiance()
    vmap = viewer_equirect.to_viewer(env, 0.0)
    if not np.isfinite(vmap).all():
        raise ValueError("the resampled environment holds NaN or Inf")  # cannot happen: lookup of a checked map
    doc = b.document(BIN)
    side = sidecar_document(scene, objects, camera_node, b.cameras[0]["perspective"], vmap.shape, content_id)
    with atomic_folder(folder, sidecar.is_export, "iblcheck export", FILES) as tmp:
        (tmp / GLTF).write_bytes(json_bytes(doc))
        (tmp / BIN).write_bytes(b.binary())
        imageio.write_hdr(tmp / ENVIRONMENT, vmap)
        if fidelity_scenario:
            fidelity.write_files(tmp, scene, GLTF, ENVIRONMENT, vmap)
        (tmp / sidecar.NAME).write_bytes(json_bytes(side))
    return Exported(folder, folder / GLTF, folder / ENVIRONMENT, folder / sidecar.NAME,
                    folder / fidelity.SCENARIO if fidelity_scenario else None, tuple(warns))
