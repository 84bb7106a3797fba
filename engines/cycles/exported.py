"""The files `iblcheck export` writes, read without bpy: the sidecar, the glTF meshes, the camera.

Only what the bridge needs is read, and everything is checked: a wrong key or value is an SceneRejected naming
the file, the key and the value (the bridge's exit code 2). The glTF meshes are read from their buffers
directly (never through Blender's importer), so the positions and normals Cycles gets are the exported
float32 arrays bit for bit (the axis change is exact, axes.py).
"""

from __future__ import annotations

import base64
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from engines.cycles.errors import SceneRejected, short_repr

SIDECAR_LIMIT = 16 * 2**20
GLTF_LIMIT = 64 * 2**20
BUFFER_LIMIT = 2**31
#: glTF accessor componentType -> numpy dtype (the ones an export uses: float positions and normals,
#: unsigned integer indices)
COMPONENT = {5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5121: np.uint8}
WIDTH = {"SCALAR": 1, "VEC3": 3}
#: the scene default of `reference.max_depth` (scenes/model/scene.py `Reference`; a test checks they agree),
#: used when the sidecar does not say
DEFAULT_MAX_DEPTH = 16
IDENTITY = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]


@dataclass(frozen=True)
class Object:
    name: str
    material: dict  # iblcheck's own material dict (scenes.model.materials.used_fields)
    positions: np.ndarray  # (N, 3) float32, glTF (iblcheck) world axes
    normals: np.ndarray  # (N, 3) float32
    indices: np.ndarray  # (M, 3) uint32


@dataclass(frozen=True)
class View:
    """The sidecar's camera (gluLookAt, glTF axes) and image."""
    position: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float]
    yfov_deg: float
    width: int
    height: int


@dataclass(frozen=True)
class Export:
    sidecar: Path
    view: View
    environment: Path
    rotation_y_deg: float
    intensity: float
    objects: tuple[Object, ...]
    #: Mitsuba's max_depth of the reference (path segments; 2 = direct lighting): the sidecar's optional
    #: `reference.max_depth`, else the scene default
    max_depth: int
    #: the reference's samples per pixel (the sidecar's optional `reference.spp`), the bridge's default --spp
    spp: int | None = None


def _get(tree: dict, key: str, path: Path, kind: type | tuple = (int, float)):
    """tree[last part of key] of the expected type; `key` is the dotted name used in messages."""
    name = key.rsplit(".", 1)[-1]
    if not isinstance(tree, dict) or name not in tree:
        raise SceneRejected(f"{path}: key {key} is missing")
    value = tree[name]
    if not isinstance(value, kind) or isinstance(value, bool) and kind is not bool:
        raise SceneRejected(f"{path}: key {key} = {short_repr(value)} has the wrong type")
    if isinstance(value, float) and not math.isfinite(value):
        raise SceneRejected(f"{path}: key {key} = {value} is not finite")
    return value


def _vec3(tree: dict, key: str, path: Path) -> tuple[float, float, float]:
    value = _get(tree, key, path, list)
    if len(value) != 3 or not all(isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
                                  for x in value):
        raise SceneRejected(f"{path}: key {key} = {short_repr(value)} is not 3 finite numbers")
    return tuple(float(x) for x in value)


def read(sidecar: str | Path) -> Export:
    path = Path(sidecar)
    try:
        tree = json.loads(read_input(path, "export sidecar", SIDECAR_LIMIT, SceneRejected))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise SceneRejected(f"{path}: not a JSON export sidecar ({exc})") from None
    if not isinstance(tree, dict) or tree.get("format") != "iblcheck-export":
        raise SceneRejected(f"{path}: key format = {short_repr(tree.get('format') if isinstance(tree, dict) else tree)}"
                         " is not 'iblcheck-export'")
    folder = path.parent
    env = _get(tree, "environment", path, dict)
    cam = _get(tree, "camera", path, dict)
    image = _get(tree, "image", path, dict)
    width, height = _get(image, "image.width", path, int), _get(image, "image.height", path, int)
    if not (1 <= width <= 16384 and 1 <= height <= 16384):
        raise SceneRejected(f"{path}: key image = {width} x {height} is not 1..16384 pixels a side")
    yfov_deg = float(_get(cam, "camera.yfov_deg", path))
    if not 0.0 < yfov_deg < 180.0:
        raise SceneRejected(f"{path}: key camera.yfov_deg = {yfov_deg} is not in (0, 180)")
    view = View(position=_vec3(cam, "camera.position", path), target=_vec3(cam, "camera.target", path),
                up=_vec3(cam, "camera.up", path), yfov_deg=yfov_deg, width=width, height=height)
    forward = np.subtract(view.target, view.position)
    if np.linalg.norm(forward) == 0.0 or np.linalg.norm(np.cross(forward, view.up)) == 0.0:
        raise SceneRejected(f"{path}: key camera: position {view.position}, target {view.target} and up {view.up} "
                            "give no camera frame (target on the position or up along the view)")
    reference = tree.get("reference", {})
    max_depth = reference.get("max_depth", DEFAULT_MAX_DEPTH) if isinstance(reference, dict) else None
    if not isinstance(max_depth, int) or isinstance(max_depth, bool) or max_depth < 2:
        raise SceneRejected(f"{path}: key reference.max_depth = {short_repr(max_depth)} is not an integer >= 2")
    spp = reference.get("spp") if isinstance(reference, dict) else None
    if spp is not None and (not isinstance(spp, int) or isinstance(spp, bool) or spp < 1):
        raise SceneRejected(f"{path}: key reference.spp = {short_repr(spp)} is not a positive integer")
    gltf_path = folder / _get(tree, "gltf", path, str)
    return Export(sidecar=path, view=view, environment=folder / _get(env, "environment.file", path, str),
                  rotation_y_deg=float(_get(env, "environment.rotation_y_deg", path)),
                  intensity=float(_get(env, "environment.intensity", path)),
                  objects=tuple(_objects(tree, gltf_path, path)), max_depth=max_depth, spp=spp)


def read_input(path: Path, kind: str, limit: int, error: type[Exception] = SceneRejected) -> bytes:
    """The bytes of a regular file of at most `limit` bytes, else `error` naming the path and the problem."""
    try:
        if not path.is_file():
            raise error(f"{path}: {kind} not found or not a regular file")
        size = path.stat().st_size
        if size > limit:
            raise error(f"{path}: {kind} of {size} bytes, more than the limit of {limit}")
        return path.read_bytes()
    except OSError as exc:
        raise error(f"{path}: {kind} cannot be read ({exc.strerror or exc})") from None


def _objects(tree: dict, gltf_path: Path, path: Path) -> list[Object]:
    objects = _get(tree, "objects", path, list)
    try:
        gltf = json.loads(read_input(gltf_path, "glTF file", GLTF_LIMIT, SceneRejected))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise SceneRejected(f"{gltf_path}: not a glTF 2.0 JSON file ({exc})") from None
    meshes = gltf.get("meshes", []) if isinstance(gltf, dict) else []
    for node in gltf.get("nodes", []):
        moved = any(k in node for k in ("translation", "rotation", "scale")) or node.get("matrix", IDENTITY) != IDENTITY
        if "mesh" in node and moved:
            raise SceneRejected(f"{gltf_path}: node {short_repr(node.get('name', ''))} has a transform; an export's "
                             "meshes are in world space with identity nodes")
    reader = _Buffers(gltf, gltf_path)
    out = []
    for i, obj in enumerate(objects):
        key = f"objects[{i}]"
        name = _get(obj, f"{key}.name", path, str)
        material = _get(obj, f"{key}.material", path, dict)
        ref = obj.get("mesh", i)
        index = ref if isinstance(ref, int) and not isinstance(ref, bool) else next(
            (j for j, m in enumerate(meshes) if m.get("name") == ref), None)
        if index is None or not 0 <= index < len(meshes):
            raise SceneRejected(f"{path}: key {key}.mesh = {short_repr(ref)} names no mesh of {gltf_path.name}")
        prims = meshes[index].get("primitives", [])
        if len(prims) != 1 or prims[0].get("mode", 4) != 4:
            raise SceneRejected(f"{gltf_path}: mesh {index} is not one triangle-list primitive")
        attrs = prims[0].get("attributes", {})
        if "POSITION" not in attrs or "NORMAL" not in attrs or "indices" not in prims[0]:
            raise SceneRejected(f"{gltf_path}: mesh {index} lacks POSITION, NORMAL or indices")
        positions = reader.accessor(attrs["POSITION"], "VEC3", (np.float32,))
        normals = reader.accessor(attrs["NORMAL"], "VEC3", (np.float32,))
        indices = reader.accessor(prims[0]["indices"], "SCALAR", (np.uint32, np.uint16, np.uint8)).astype(np.uint32)
        if len(normals) != len(positions) or len(indices) % 3 or (len(indices) and indices.max() >= len(positions)):
            raise SceneRejected(f"{gltf_path}: mesh {index} has {len(positions)} positions, {len(normals)} normals "
                             f"and {len(indices)} indices (not whole triangles within the vertices)")
        if not (np.isfinite(positions).all() and np.isfinite(normals).all()):
            raise SceneRejected(f"{gltf_path}: mesh {index} holds non-finite positions or normals")
        out.append(Object(name=name, material=material, positions=positions, normals=normals,
                          indices=indices.reshape(-1, 3)))
    return out


class _Buffers:
    """glTF accessors as numpy arrays (buffers: a file beside the glTF or a base64 data URI)."""

    def __init__(self, gltf: dict, path: Path) -> None:
        self.gltf, self.path, self.cache = gltf, path, {}

    def _buffer(self, i: int) -> bytes:
        if i not in self.cache:
            uri = self.gltf["buffers"][i].get("uri", "")
            if uri.startswith("data:"):
                self.cache[i] = base64.b64decode(uri.split(",", 1)[1])
            else:
                self.cache[i] = read_input(self.path.parent / uri, "glTF buffer", BUFFER_LIMIT, SceneRejected)
        return self.cache[i]

    def accessor(self, i: int, kind: str, dtypes: tuple) -> np.ndarray:
        try:
            acc = self.gltf["accessors"][i]
            view = self.gltf["bufferViews"][acc["bufferView"]]
            dtype = np.dtype(COMPONENT[acc["componentType"]])
            if acc["type"] != kind or dtype.type not in dtypes:
                raise KeyError("type")
            width, count = WIDTH[kind], int(acc["count"])
            data = self._buffer(view["buffer"])
            start = int(view.get("byteOffset", 0)) + int(acc.get("byteOffset", 0))
            stride = int(view.get("byteStride", width * dtype.itemsize))
            end = start + (count - 1) * stride + width * dtype.itemsize if count else start
            if end > int(view.get("byteOffset", 0)) + int(view["byteLength"]) or end > len(data):
                raise KeyError("range")
            arr = np.ndarray((count, width), dtype=dtype.newbyteorder("<"), buffer=data, offset=start,
                             strides=(stride, dtype.itemsize))
        except (KeyError, IndexError, TypeError, ValueError) as exc:
            raise SceneRejected(f"{self.path}: accessor {i} is not a readable {kind} of {[d.__name__ for d in dtypes]} "
                             f"({exc})") from None
        arr = np.array(arr, dtype=dtype.newbyteorder("="))
        return arr[:, 0] if kind == "SCALAR" else arr
