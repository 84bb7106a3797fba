"""glTF Render Fidelity scenarios (google/model-viewer packages/render-fidelity-tools, also used by
KhronosGroup/glTF-Render-Fidelity): write one for an iblcheck scene, and read one as an iblcheck Scene.

A scenario (render-fidelity-tools src/common.ts `ScenarioConfig`, defaults from src/config-reader.ts):

    {"name", "model": glTF path, "lighting": equirect .hdr path (relative to the scenario file),
     "dimensions": {"width": 768, "height": 768}, "target": {"x": 0, "y": 0, "z": 0},
     "orbit": {"theta": 0, "phi": 90, "radius": 1}, "verticalFoV": 45, "renderSkybox": false}

The orbit is model-viewer's camera-orbit in degrees: theta the azimuth about +Y from +Z towards +X, phi
the polar angle from +Y; the eye is target + radius (sin phi sin theta, cos phi, sin phi cos theta), and
the camera looks at the target with up = +Y (the harness's Filament renderer: `camera.lookAt(eye, center,
[0, 1, 0])`; a radius <= 0 puts the eye on the target looking along -(that unit vector)). verticalFoV is
in degrees. The lighting is in the viewer convention (scenes/exchange/viewer_equirect.py) with no rotation.

What a scenario cannot say, and so what `check_expressible` refuses: an up vector that tilts the image
(the orbit camera's up is +Y), a camera looking straight up or down (no azimuth), and with it any roll.
An environment rotation is baked into the scenario's lighting (its texels are the rotated lookups).
Reading refuses textured materials, emission, blending and BRDF extensions (gltf_materials.from_gltf).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from scenes.environment import envmap
from scenes.exchange import gltf_materials, gltf_reader, viewer_equirect
from scenes.exchange.gltf_writer import Builder, json_bytes
from scenes.model.camera import Camera
from scenes.model.scene import from_dict
from scenes.storage import imageio
from scenes.storage.disk_cache import cache_dir
from scenes.storage.errors import InputError
from scenes.storage.files import read_input, write_bytes

SCENARIO = "scenario.json"
LIGHTING = "scenario-lighting.hdr"
DEFAULTS = {"dimensions": {"width": 768, "height": 768}, "target": {"x": 0.0, "y": 0.0, "z": 0.0},
            "orbit": {"theta": 0.0, "phi": 90.0, "radius": 1.0}, "verticalFoV": 45.0, "renderSkybox": False,
            "lighting": "../../../shared-assets/environments/lightroom_14b.hdr"}
MAX_BYTES = 16 << 20


def orbit_direction(theta_deg: float, phi_deg: float) -> np.ndarray:
    """The unit vector from the target to the eye of model-viewer's orbit (theta, phi) in degrees."""
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(p) * np.sin(t), np.cos(p), np.sin(p) * np.cos(t)])


def check_expressible(scene) -> None:
    """Refuse (InputError naming the key) a camera a scenario's orbit cannot reproduce."""
    cam = scene.camera
    forward = np.subtract(cam.target, cam.origin)
    forward = forward / np.linalg.norm(forward)
    if np.hypot(forward[0], forward[2]) < 1e-9:
        raise InputError(f"{scene.path}: camera.target - camera.origin = {forward.tolist()}: a Render Fidelity "
                         "orbit camera looking straight up or down has no defined azimuth (its up is +Y)")
    if not np.allclose(Camera(cam.origin, cam.target, (0.0, 1.0, 0.0)).basis()[0], cam.basis()[0], atol=1e-12):
        raise InputError(f"{scene.path}: camera.up = {list(cam.up)}: a Render Fidelity scenario's orbit camera "
                         "has up = +Y (model-viewer's camera-orbit, Filament's lookAt with [0, 1, 0]); this up "
                         "rolls the image, which a scenario cannot say")


def scenario_of(scene, model: str, lighting: str) -> dict:
    """The scenario dict of a scene (its camera as an orbit about its target)."""
    cam = scene.camera
    offset = np.subtract(cam.origin, cam.target).astype(np.float64)
    radius = float(np.linalg.norm(offset))
    return {"name": scene.name, "model": model, "lighting": lighting,
            "dimensions": {"width": cam.width, "height": cam.height},
            "target": dict(zip("xyz", (float(v) for v in cam.target), strict=True)),
            "orbit": {"theta": float(np.degrees(np.arctan2(offset[0], offset[2]))),
                      "phi": float(np.degrees(np.arccos(np.clip(offset[1] / radius, -1.0, 1.0)))),
                      "radius": radius},
            "verticalFoV": float(cam.fov_deg), "renderSkybox": True}


def write_files(folder: Path, scene, model: str, environment: str, vmap: np.ndarray) -> None:
    """scenario.json (and, for a rotated environment, its rotation baked into scenario-lighting.hdr)."""
    check_expressible(scene)
    lighting = environment
    if scene.environment.rotation_deg != 0.0:
        lighting = LIGHTING
        imageio.write_hdr(folder / LIGHTING,
                          viewer_equirect.to_viewer(scene.environment.radiance(), scene.environment.rotation_deg))
    (folder / SCENARIO).write_bytes(json_bytes(scenario_of(scene, model, lighting)))


def _merged(raw: dict) -> dict:
    out = {**DEFAULTS, **raw}
    for key in ("dimensions", "target", "orbit"):
        given = raw.get(key, {})
        if not isinstance(given, dict):
            raise InputError(f"{key} = {given!r}: must be an object")
        out[key] = {**DEFAULTS[key], **given}
    return out


def read_json(path: Path) -> dict:
    """One scenario from a scenario file or a harness config with exactly one scenario, defaults filled in."""
    data = read_input(path, "Render Fidelity scenario", MAX_BYTES, InputError)
    try:
        doc = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not a JSON scenario ({exc})") from None
    if isinstance(doc, dict) and isinstance(doc.get("scenarios"), list):
        if len(doc["scenarios"]) != 1:
            raise InputError(f"{path}: scenarios holds {len(doc['scenarios'])} scenarios; give a file with one")
        doc = doc["scenarios"][0]
    if not isinstance(doc, dict) or not isinstance(doc.get("model"), str):
        raise InputError(f"{path}: model: missing; a Render Fidelity scenario names its glTF model")
    try:
        return _merged(doc)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def _number(s: dict, key: str, path: Path) -> float:
    parent, _, child = key.partition(".")
    value = s[parent][child] if child else s[parent]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise InputError(f"{path}: {key} = {value!r}: must be a finite number")
    return float(value)


def _cached(data: bytes, suffix: str) -> Path:
    """`data` in the cache folder under its SHA-256 (the scene model reads meshes and maps from files)."""
    folder = cache_dir() / "scenarios"
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / f"{hashlib.sha256(data).hexdigest()[:32]}{suffix}"
    if not out.is_file():
        write_bytes(out, data)
    return out


def _mesh_file(part: gltf_reader.Part) -> Path:
    b = Builder()
    normals = part.normals if part.normals is not None else np.zeros_like(part.positions)
    b.add_mesh(part.name, part.positions, normals, part.indices, b.add_material({"name": "m"}))
    return _cached(b.glb("iblcheck scenario part"), ".glb")


def _lighting_file(path: Path) -> Path:
    vmap = envmap.read(path)
    converted = viewer_equirect.from_viewer(vmap)
    key = hashlib.sha256(converted.tobytes() + str(converted.shape).encode()).hexdigest()[:32]
    out = cache_dir() / "scenarios" / f"{key}.exr"
    if not out.is_file():
        out.parent.mkdir(parents=True, exist_ok=True)
        envmap.write(out, converted)
    return out


def read_scenario(path: str | Path):
    """An iblcheck Scene of a Render Fidelity scenario file (see the module docstring)."""
    path = Path(path)
    s = read_json(path)
    base = path.resolve().parent
    model = base / s["model"]
    lighting = base / str(s["lighting"])
    theta, phi, radius = (_number(s, f"orbit.{k}", path) for k in ("theta", "phi", "radius"))
    target = np.array([_number(s, f"target.{k}", path) for k in "xyz"])
    fov = _number(s, "verticalFoV", path)
    width, height = (_number(s, f"dimensions.{k}", path) for k in ("width", "height"))
    offset = orbit_direction(theta, phi)
    if radius > 0:
        eye = target + radius * offset
    else:  # the harness: the eye on the target, looking along -offset
        eye, target = target, target - offset
    doc, meshes = gltf_reader.parts(model)
    objects = []
    for part in meshes:
        mat = gltf_materials.from_gltf(doc, part.material, f"{model}: {part.name}")
        objects.append({"shape": str(_mesh_file(part)), "normals": "file" if part.normals is not None else "flat",
                        "material": mat})
    tree = {"name": str(s.get("name") or path.stem),
            "environment": {"map": str(_lighting_file(lighting))},
            "camera": {"origin": [float(v) for v in eye], "target": [float(v) for v in target], "up": [0.0, 1.0, 0.0],
                       "fov_deg": fov, "width": int(width) if width == int(width) else width,
                       "height": int(height) if height == int(height) else height},
            "objects": objects}
    if any(o["material"]["type"] == "pbr" for o in objects):
        tree["realtime"] = {"glossy": "split_sum"}  # the real-time technique that shades glTF's material
    return from_dict(tree, str(path), base_dir=base, name_default=path.stem)
