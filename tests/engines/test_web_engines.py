"""three.js and Babylon.js through engines/web/render.mjs (headless Chromium, SwiftShader on the CPU).

The scenes are written here, in the export's format (scene.gltf + .bin, environment.hdr in the glTF viewers'
equirect convention, iblcheck-export.json), independently of scenes.exchange, and every expectation is computed
here in numpy:
- linearity: a constant environment of radiance L is seen in the background as L (1 %), for L = 0.5 and 2.0,
  so nothing tone-maps, clamps or encodes the output; control: an sRGB-encoded or Reinhard-mapped L is rejected;
- orientation: a mirror sphere under a map with three coloured discs; a numpy ray trace (iblcheck's pixel rays,
  the analytic sphere, the reflected ray looked up in the viewer convention at R_y(-theta) d) predicts where each
  disc appears; each engine's disc centroids are within 2 px; controls: the same prediction under the map mirrored
  in x or in z, turned by 90 degrees, or turned the wrong way is rejected by the same check;
- exit codes: a missing sidecar gives 2, a missing Chromium 3, each with one `error:` line.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from scenes.model.camera import Camera
from scenes.storage.imageio import read_exr, write_hdr

REPO = Path(__file__).resolve().parents[2]
WEB = REPO / "engines" / "web"
ENGINES = ["threejs", "babylon"]


def _chromium() -> str | None:
    return os.environ.get("IBLCHECK_CHROMIUM") or next(
        (p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)


def _web_missing() -> str | None:
    if shutil.which("node") is None:
        return "node is not installed (Debian's nodejs; make setup installs it as root)"
    if _chromium() is None:
        return "no Chromium on PATH (Debian's chromium; make setup installs it as root)"
    for pkg in ("puppeteer-core", "three", "@babylonjs/core", "@babylonjs/loaders"):
        if not (WEB / "node_modules" / pkg / "package.json").exists():
            return f"engines/web/node_modules lacks {pkg}: run `npm ci --prefix engines/web` (make setup)"
    return None


needs_web = pytest.mark.skipif(_web_missing() is not None, reason=str(_web_missing()))
pytestmark = pytest.mark.browser


# --------------------------------------------------------------------------- the scene files, written here


def uv_sphere(radius: float, rings: int = 64, segments: int = 128) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, exact unit normals (float32) and uint32 indices of a UV sphere about the origin, wound
    counter-clockwise seen from outside (glTF's front faces)."""
    th = np.linspace(0.0, np.pi, rings + 1)
    ph = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    t, p = np.meshgrid(th, ph, indexing="ij")
    n = np.stack([np.sin(t) * np.cos(p), np.cos(t), -np.sin(t) * np.sin(p)], axis=-1).reshape(-1, 3)
    idx = []
    for i in range(rings):
        for j in range(segments):
            a, b = i * (segments + 1) + j, (i + 1) * (segments + 1) + j
            idx += [a, b, a + 1, a + 1, b, b + 1]
    return (n * radius).astype(np.float32), n.astype(np.float32), np.asarray(idx, dtype=np.uint32)


def write_gltf(folder: Path, positions: np.ndarray, normals: np.ndarray, indices: np.ndarray,
               base_color=(1.0, 1.0, 1.0), metallic: float = 1.0, roughness: float = 0.0) -> None:
    blob = positions.tobytes() + normals.tobytes() + indices.tobytes()
    (folder / "scene.bin").write_bytes(blob)
    nv, npos = len(positions), positions.nbytes
    doc = {
        "asset": {"version": "2.0", "generator": "tests/engines/test_web_engines.py"},
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "sphere"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"name": "m", "pbrMetallicRoughness": {"baseColorFactor": [*base_color, 1.0],
                                                            "metallicFactor": metallic, "roughnessFactor": roughness}}],
        "buffers": [{"uri": "scene.bin", "byteLength": len(blob)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": npos, "target": 34962},
                        {"buffer": 0, "byteOffset": npos, "byteLength": normals.nbytes, "target": 34962},
                        {"buffer": 0, "byteOffset": 2 * npos, "byteLength": indices.nbytes, "target": 34963}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3",
             "min": positions.min(0).tolist(), "max": positions.max(0).tolist()},
            {"bufferView": 1, "componentType": 5126, "count": nv, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5125, "count": len(indices), "type": "SCALAR"}],
    }
    (folder / "scene.gltf").write_text(json.dumps(doc))


def write_export(folder: Path, env: np.ndarray, camera: Camera, rotation_y_deg: float = 0.0,
                 radius: float = 1.0, **material) -> Path:
    """The export's three files for one sphere of `radius` at the origin; returns the sidecar."""
    folder.mkdir(parents=True, exist_ok=True)
    write_gltf(folder, *uv_sphere(radius), **material)
    write_hdr(folder / "environment.hdr", env)
    sidecar = {
        "format": "iblcheck-export", "version": 1, "scene": "test", "gltf": "scene.gltf",
        "environment": {"file": "environment.hdr", "width": env.shape[1], "height": env.shape[0],
                        "convention": "u = 0.5 + atan2(d.z, d.x) / (2 pi), row 0 is +Y",
                        "rotation_y_deg": rotation_y_deg, "intensity": 1.0},
        "camera": {"node": None, "yfov": float(np.radians(camera.fov_deg)), "yfov_deg": camera.fov_deg,
                   "aspect_ratio": camera.aspect, "znear": 0.1, "zfar": 100.0, "position": list(camera.origin),
                   "target": list(camera.target), "up": list(camera.up)},
        "image": {"width": camera.width, "height": camera.height, "pixel_center": [0.5, 0.5],
                  "row_order": "top row first", "exposure": 1.0, "background": "the environment"},
        "objects": [],
    }
    path = folder / "iblcheck-export.json"
    path.write_text(json.dumps(sidecar, indent=1))
    return path


def run_bridge(engine: str, sidecar: Path, out: Path, env: dict | None = None,
               timings: Path | None = None) -> subprocess.CompletedProcess:
    cmd = ["node", str(WEB / "render.mjs"), "--engine", engine, "--sidecar", str(sidecar), "--output", str(out),
           "--frames", "2", "--warmup", "0"]
    if timings is not None:
        cmd += ["--timings", str(timings)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300, env={**os.environ, **(env or {})})


def render(engine: str, sidecar: Path) -> np.ndarray:
    out = sidecar.parent / f"{engine}.exr"
    proc = run_bridge(engine, sidecar, out)
    assert proc.returncode == 0, proc.stderr
    return read_exr(out)


# --------------------------------------------------------------------------- the numpy prediction


def viewer_direction(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The world direction of equirect coordinates in the glTF viewers' convention (three.js equirectUv):
    u = 0.5 + atan2(z, x) / (2 pi), v = acos(y) / pi from the top row."""
    phi, theta = 2.0 * np.pi * (u - 0.5), np.pi * v
    return np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)], axis=-1)


def viewer_lookup(env: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Nearest-texel lookup of `env` in the viewer convention (the discs are many texels wide)."""
    h, w = env.shape[:2]
    u = 0.5 + np.arctan2(d[..., 2], d[..., 0]) / (2.0 * np.pi)
    v = np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / np.pi
    return env[np.clip((v * h).astype(int), 0, h - 1), (u * w).astype(int) % w]


def rot_y(deg: float) -> np.ndarray:
    """Right-handed rotation about +Y (counter-clockwise seen from +Y), as Mitsuba's rotate([0, 1, 0], deg)."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def trace_mirror_sphere(env: np.ndarray, camera: Camera, rotation_y_deg: float, radius: float = 1.0,
                        k: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """(image, hit fraction) of a perfect mirror sphere at the origin under `env` (viewer convention), the
    radiance from world direction d being env's at R_y(-theta) d; k x k rays per pixel."""
    d = camera.subpixel_rays(k)
    o = np.asarray(camera.origin, dtype=np.float64)
    b = d @ o
    disc = b * b - (o @ o - radius * radius)
    hit = disc > 0.0
    t = -b - np.sqrt(np.where(hit, disc, 0.0))
    n = (o + t[..., None] * d) / radius
    r = d - 2.0 * np.sum(d * n, axis=-1, keepdims=True) * n
    world = np.where(hit[..., None], r, d)
    rgb = viewer_lookup(env, world @ rot_y(rotation_y_deg))  # row vectors: d @ R = R^T d = R_y(-theta) d
    return rgb.mean(axis=2), hit.mean(axis=2)


# three discs of different colours at directions facing the camera (so the mirror sphere shows them, away
# from its silhouette), none symmetric to another under a mirror or a quarter turn
DISCS = {0: (0.60, 0.40), 1: (0.70, 0.55), 2: (0.82, 0.45)}  # channel: (u, v) in the viewer convention
DISC_RADIUS_DEG = 6.0
GREY = 0.05


def marked_map(width: int = 256) -> np.ndarray:
    h = width // 2
    v, u = (np.mgrid[0:h, 0:width] + 0.5) / np.array([h, width])[:, None, None]
    d = viewer_direction(u, v)
    env = np.full((h, width, 3), GREY, dtype=np.float32)
    for ch, (uc, vc) in DISCS.items():
        inside = d @ viewer_direction(np.float64(uc), np.float64(vc)) > np.cos(np.radians(DISC_RADIUS_DEG))
        env[inside, ch] = 4.0
    return env


def centroids(img: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(column, row) centroid of each disc's colour inside `mask`; NaN where that colour is absent. A disc's
    weight is its channel above the mean of the other two (grey and the other discs cancel)."""
    out = np.full((3, 2), np.nan)
    rows, cols = np.mgrid[0:img.shape[0], 0:img.shape[1]] + 0.5
    for ch in range(3):
        others = [c for c in range(3) if c != ch]
        w = np.clip(img[..., ch] - img[..., others].max(axis=-1), 0.0, None) * mask
        if w.sum() > 0.5:
            out[ch] = [(w * cols).sum() / w.sum(), (w * rows).sum() / w.sum()]
    return out


def max_offset(a: np.ndarray, b: np.ndarray) -> float:
    """Largest centroid distance in pixels; infinite where a disc is seen in one image and not the other."""
    dist = np.hypot(*(a - b).T)
    return float(np.inf) if np.isnan(dist).any() else float(dist.max())


# --------------------------------------------------------------------------- tests

CAMERA = Camera(origin=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov_deg=30.0,
                width=64, height=64)


@needs_web
@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("radiance", [0.5, 2.0])
def test_constant_environment_is_seen_unchanged(engine: str, radiance: float, tmp_path: Path) -> None:
    """The background of a constant environment is L in every pixel the sphere does not cover: the output is
    linear radiance, neither tone-mapped, nor clamped to 1, nor sRGB-encoded."""
    camera = Camera(origin=(0.0, 0.0, 4.0), fov_deg=30.0, width=48, height=32)
    env = np.full((32, 64, 3), radiance, dtype=np.float32)
    img = render(engine, write_export(tmp_path, env, camera, radius=0.5, metallic=1.0, roughness=0.0))
    assert img.shape == (32, 48, 3) and img.dtype == np.float32
    assert np.isfinite(img).all()
    _, hit = trace_mirror_sphere(env, camera, 0.0, radius=0.5, k=2)
    background = img[hit == 0.0]
    assert len(background) > 0.5 * img.shape[0] * img.shape[1]
    assert np.abs(background / radiance - 1.0).max() < 0.01
    # controls: what a display transform would have written is rejected by the same bound
    srgb = 1.055 * min(radiance, 1.0) ** (1 / 2.4) - 0.055
    for wrong in (srgb, radiance / (1.0 + radiance), min(radiance, 1.0)):
        if wrong != radiance:
            assert np.abs(background / wrong - 1.0).max() >= 0.01


@needs_web
@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("rotation", [0.0, 40.0])
def test_mirror_sphere_shows_the_discs_where_the_ray_trace_does(engine: str, rotation: float, tmp_path: Path) -> None:
    env = marked_map()
    img = render(engine, write_export(tmp_path, env, CAMERA, rotation, metallic=1.0, roughness=0.0))
    assert img.shape == (64, 64, 3) and np.isfinite(img).all()
    _, hit = trace_mirror_sphere(env, CAMERA, rotation)
    mask = hit == 1.0
    predicted = centroids(trace_mirror_sphere(env, CAMERA, rotation)[0], mask)
    seen = centroids(img, mask)
    assert not np.isnan(predicted).any(), "every disc is on the sphere in the prediction"
    assert max_offset(seen, predicted) < 2.0, f"seen {seen.round(2).tolist()} predicted {predicted.round(2).tolist()}"
    # controls: the map mirrored in x (u -> 0.5 - u) or in z (u -> 1 - u), turned a quarter, turned the wrong way
    h, w = env.shape[:2]
    cols = np.arange(w)
    wrong = {"mirror x": (env[:, (w // 2 - 1 - cols) % w], rotation),
             "mirror z": (env[:, ::-1], rotation),
             "quarter turn": (np.roll(env, w // 4, axis=1), rotation)}
    if rotation:
        wrong["rotation sign"] = (env, -rotation)
    for name, (m, rot) in wrong.items():
        control = centroids(trace_mirror_sphere(m, CAMERA, rot)[0], mask)
        assert max_offset(seen, control) > 2.0, name


@needs_web
@pytest.mark.parametrize("engine", ENGINES)
def test_missing_sidecar_exits_2(engine: str, tmp_path: Path) -> None:
    proc = run_bridge(engine, tmp_path / "nothing.json", tmp_path / "out.exr")
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "nothing.json" in lines[0]
    assert not (tmp_path / "out.exr").exists()


@needs_web
@pytest.mark.parametrize("engine", ENGINES)
def test_missing_chromium_exits_3(engine: str, tmp_path: Path) -> None:
    sidecar = write_export(tmp_path, np.ones((8, 16, 3), np.float32), CAMERA)
    proc = run_bridge(engine, sidecar, tmp_path / "out.exr", env={"IBLCHECK_CHROMIUM": str(tmp_path / "no-chromium")})
    assert proc.returncode == 3
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "no-chromium" in lines[0]
    # control: the same scene with the browser present renders (exit 0), so 3 came from the missing browser
    assert run_bridge(engine, sidecar, tmp_path / "out.exr").returncode == 0
