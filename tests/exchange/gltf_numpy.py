"""A glTF reader and a viewer-convention environment lookup written apart from scenes/exchange, for the
export's tests: what an engine would compute from the exported files, in numpy."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

DTYPES = {5125: "<u4", 5126: "<f4", 5123: "<u2"}
COMPONENTS = {"SCALAR": 1, "VEC3": 3}


def read_gltf(path: Path) -> tuple[dict, dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]]:
    """(the JSON, {mesh index: (positions, normals, indices)}) read straight from scene.gltf + its .bin."""
    doc = json.loads(path.read_text())
    blob = (path.parent / doc["buffers"][0]["uri"]).read_bytes()

    def acc(i):
        a = doc["accessors"][i]
        v = doc["bufferViews"][a["bufferView"]]
        n = a["count"] * COMPONENTS[a["type"]]
        arr = np.frombuffer(blob, dtype=DTYPES[a["componentType"]], count=n,
                            offset=v.get("byteOffset", 0) + a.get("byteOffset", 0))
        return arr.reshape(a["count"], COMPONENTS[a["type"]])

    meshes = {}
    for m, mesh in enumerate(doc["meshes"]):
        prim = mesh["primitives"][0]
        meshes[m] = (acc(prim["attributes"]["POSITION"]), acc(prim["attributes"]["NORMAL"]),
                     acc(prim["indices"]).reshape(-1, 3))
    return doc, meshes


def quat_matrix(q) -> np.ndarray:
    """3x3 rotation of a unit quaternion (x, y, z, w) (glTF's order)."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def rot_y(deg: float) -> np.ndarray:
    """Right-handed rotation about +Y (counter-clockwise seen from +Y): +Z turns towards +X."""
    t = np.radians(deg)
    return np.array([[np.cos(t), 0, np.sin(t)], [0, 1, 0], [-np.sin(t), 0, np.cos(t)]])


def viewer_lookup(vmap: np.ndarray, d: np.ndarray, quarter_turn: bool = True) -> np.ndarray:
    """three.js's equirectUv + flipY + bilinear: u = atan(z, x)/2pi + 0.5, row 0 = +Y, texel centres at
    +0.5, columns wrapping, rows clamped. `quarter_turn=False` is a wrong reading (iblcheck's own u =
    atan2(x, -z)/2pi), a negative control."""
    h, w = vmap.shape[:2]
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    if quarter_turn:
        u = np.arctan2(d[..., 2], d[..., 0]) / (2 * np.pi) + 0.5
    else:
        u = np.arctan2(d[..., 0], -d[..., 2]) / (2 * np.pi)
    u = np.mod(u, 1.0)
    t = np.arccos(np.clip(d[..., 1], -1, 1)) / np.pi
    x = u * w - 0.5
    y = np.clip(t * h - 0.5, 0, h - 1)
    x0 = np.floor(x).astype(int)
    y0 = np.minimum(np.floor(y).astype(int), h - 2)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    c0, c1 = x0 % w, (x0 + 1) % w
    v = vmap.astype(np.float64)
    return ((v[y0, c0] * (1 - fx) + v[y0, c1] * fx) * (1 - fy)
            + (v[y0 + 1, c0] * (1 - fx) + v[y0 + 1, c1] * fx) * fy)


def centre_direction(r, c, h: int, w: int) -> np.ndarray:
    """Map-frame direction of viewer texel (r, c)'s centre."""
    u = (np.asarray(c) + 0.5) / w
    t = (np.asarray(r) + 0.5) / h
    phi, theta = 2 * np.pi * (u - 0.5), np.pi * t
    return np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)], axis=-1)


def camera_rays(node: dict, camera: dict, width: int, height: int, centre=(0.5, 0.5),
                fov_is_horizontal: bool = False) -> np.ndarray:
    """Unit world rays (H, W, 3) of a glTF perspective camera node: looks down -Z, +Y up, yfov vertical."""
    p = camera["perspective"]
    ty = np.tan(p["yfov"] / 2)
    tx = ty * p["aspectRatio"]
    if fov_is_horizontal:
        tx, ty = ty, ty / p["aspectRatio"]
    xs = (2 * (np.arange(width) + centre[0]) / width - 1) * tx
    ys = (1 - 2 * (np.arange(height) + centre[1]) / height) * ty
    local = np.stack(np.broadcast_arrays(xs[None, :], ys[:, None], -1.0), axis=-1)
    world = local @ quat_matrix(node["rotation"]).T
    return world / np.linalg.norm(world, axis=-1, keepdims=True)
