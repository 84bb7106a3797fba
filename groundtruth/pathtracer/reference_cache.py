"""The reference cache: rendered references keyed by everything that changes them, and nothing else.

Location: `$IBLCHECK_CACHE`, default `~/.cache/iblcheck`; one entry per key, `<key>.npz`.

- Key (`reference_key`): SHA-256 of a canonical JSON of the reference-relevant content: the
  environment's radiance bytes (so the file's bytes, scale and builtin parameters), its rotation,
  the camera, every object's mesh arrays and material, the reference settings (spp, seed,
  integrator as resolved, model, max_depth), the Mitsuba variant and version, and the plugin
  version (for a scene with a glTF "pbr" material also the `iblcheck_gltf_pbr` plugin's version and
  Smith form); with `reference.lighting = "light_array"`, the array's placement, count and a digest
  of its directions and powers (the array itself, so a change of the placement code cannot serve a
  stale entry). Real-time settings and tone mapping are not in it: a LOD bias or face size hits the
  same entry.
- Writes are atomic: a temporary file in the same folder, then `os.replace`. Each entry holds a
  SHA-256 of its arrays and metadata, checked on read; a corrupt entry is reported and re-rendered.
- Two processes rendering the same key: an advisory lock (`<key>.lock`, fcntl) makes the second
  wait and then read the first one's entry; without locking support both render and the last
  rename wins, still leaving one valid entry.
- A cache folder that cannot be written (read-only, full) is a warning, never a lost render.
"""

from __future__ import annotations

import hashlib
import json
import warnings

import numpy as np

from groundtruth.pathtracer import gltf_pbr_bsdf
from scenes.environment import light_array
from scenes.model import materials
from scenes.storage.disk_cache import CacheWarning, cache_dir, digest_arrays, locked, write_npz

__all__ = ["CacheWarning", "cache_dir", "load", "locked", "reference_key", "store", "vars_of", "write_npz"]


def reference_key(scene, env: np.ndarray, spp: int, seed: int, variant: str, mitsuba_version: str,
                  plugin_version: int, integrator: str) -> str:
    """Hex SHA-256 over what changes a reference (see the module docstring)."""
    h = hashlib.sha256()
    digest_arrays(h, env)
    cam = scene.camera
    ref = scene.reference
    desc = {
        "kind": "reference",
        "env_rotation_deg": scene.environment.rotation_deg,
        "camera": [list(cam.origin), list(cam.target), list(cam.up), cam.fov_deg, cam.width, cam.height],
        "materials": [list(vars_of(o.material).items()) for o in scene.objects],
        "spp": int(spp), "seed": int(seed), "integrator": integrator, "model": ref.model,
        "max_depth": ref.max_depth if integrator == "path" else 2,
        "variant": variant, "mitsuba": mitsuba_version, "plugin": plugin_version,
    }
    if any(o.material.type == "pbr" for o in scene.objects):  # (absent without one: earlier entries keep their keys)
        desc["gltf_pbr_plugin"] = [gltf_pbr_bsdf.PLUGIN_VERSION, gltf_pbr_bsdf.SMITH]
    if ref.lighting != "environment":  # (absent for the environment: earlier entries keep their keys)
        lights = scene.realtime.lights
        desc["lighting"] = [ref.lighting, lights.placement, lights.count,
                            light_array.content_digest(env, lights.placement, lights.count)]
    h.update(json.dumps(desc, sort_keys=True).encode())
    for obj in scene.objects:
        for arr in (obj.mesh.positions, obj.mesh.normals, obj.mesh.indices):
            digest_arrays(h, arr)
    return h.hexdigest()


def vars_of(material) -> dict:
    """The material fields that matter to its type (an unused kd must not split the cache)."""
    return materials.used_fields(material)


def _checksum(rgb: np.ndarray, mask: np.ndarray, meta_json: str) -> str:
    h = hashlib.sha256()
    digest_arrays(h, rgb)
    digest_arrays(h, mask)
    h.update(meta_json.encode())
    return h.hexdigest()


def load(key: str) -> tuple[np.ndarray, np.ndarray, dict] | None:
    """(rgb, mask, meta) of a valid entry; None when missing. A corrupt entry warns and returns None."""
    path = cache_dir() / f"{key}.npz"
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            rgb, mask = z["rgb"], z["mask"]
            meta_json, stored = str(z["meta"]), str(z["checksum"])
        if _checksum(rgb, mask, meta_json) != stored:
            raise ValueError("checksum mismatch")
        meta = json.loads(meta_json)
        problem = entry_problem(key, rgb, mask, meta)
        if problem:
            raise ValueError(problem)
        return rgb, mask, meta
    except Exception as exc:  # any unreadable entry (truncated zip, bad checksum, ...) is re-rendered
        warnings.warn(f"reference cache entry {path} is corrupt ({exc}); re-rendering it", CacheWarning,
                      stacklevel=2)
        return None


def entry_problem(key: str, rgb: np.ndarray, mask: np.ndarray, meta: object) -> str | None:
    """What is wrong with an entry's content (its checksum only proves it was written whole): the
    image an (H, W, 3) float array of finite radiance, the mask one boolean per pixel, and the
    metadata the record of this key with a positive spp and a finite, non-negative render time."""
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype.kind != "f":
        return f"rgb holds {rgb.dtype} {rgb.shape}, not (H, W, 3) floats"
    if not np.isfinite(rgb).all():
        return "rgb holds NaN or Inf"
    if mask.shape != rgb.shape[:2] or mask.dtype.kind not in "bu":
        return f"mask holds {mask.dtype} {mask.shape} for a {rgb.shape[:2]} image"
    if not isinstance(meta, dict) or meta.get("key") != key:
        return "its metadata is not this key's"
    spp, ms = meta.get("spp"), meta.get("render_ms")
    if isinstance(spp, bool) or not isinstance(spp, int) or spp < 1:
        return f"spp = {spp!r}: a positive integer is required"
    if isinstance(ms, bool) or not isinstance(ms, (int, float)) or not np.isfinite(ms) or ms < 0:
        return f"render_ms = {ms!r}: a finite time >= 0 is required"
    return None


def store(key: str, rgb: np.ndarray, mask: np.ndarray, meta: dict) -> bool:
    """Write an entry atomically; False (with a warning) when the folder cannot be written."""
    folder = cache_dir()
    meta_json = json.dumps(meta, sort_keys=True)
    try:
        write_npz(folder, key, rgb=rgb, mask=mask, meta=np.array(meta_json),
                  checksum=np.array(_checksum(rgb, mask, meta_json)))
        return True
    except OSError as exc:
        warnings.warn(f"reference cache {folder} cannot be written ({exc.strerror or exc}); "
                      "the render is returned but not cached", CacheWarning, stacklevel=2)
        return False
