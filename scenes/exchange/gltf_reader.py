"""Read a glTF 2.0 asset's triangle primitives one by one, each with its material index, in world space.

The file's structure is checked first by scenes/geometry/gltf_check.py (the specification's rules: GLB
container, node trees, URIs inside the folder, views and accessors inside their buffers). Then every
node of the default scene is walked with its world matrix (3.5.2: T R S, or `matrix`); each TRIANGLES
primitive becomes one part: positions by the world matrix, normals by its inverse transpose (None where
the primitive has no NORMAL), winding reversed where the matrix mirrors.
"""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import unquote

import numpy as np

from scenes.geometry import gltf_check
from scenes.storage.errors import InputError
from scenes.storage.files import read_input

MAX_BYTES = 1 << 30
DTYPES = {5120: "i1", 5121: "u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}


@dataclass(frozen=True)
class Part:
    name: str
    positions: np.ndarray  # (V, 3) float32, world space
    normals: np.ndarray | None  # (V, 3) float32 or None
    indices: np.ndarray  # (F, 3) int64
    material: int | None


def read_document(path: Path) -> tuple[dict, list[bytes]]:
    """(the glTF JSON, every buffer's bytes) of a .gltf or .glb file."""
    kind = path.suffix.lower().lstrip(".")
    if kind not in ("gltf", "glb"):
        raise InputError(f"{path}: a scenario's model must be a .gltf or .glb file")
    data = read_input(path, "glTF model", MAX_BYTES, InputError)
    gltf_check.check(path, kind, data)
    if kind == "glb":
        doc, glb_bin = gltf_check.split_glb(path, data)
    else:
        doc, glb_bin = json.loads(data.decode("utf-8")), None
    buffers = []
    for buffer in doc.get("buffers", []):
        uri = buffer.get("uri")
        if uri is None:
            buffers.append(glb_bin)
        elif uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.partition(",")[2]))
        else:
            buffers.append((path.parent / unquote(uri)).read_bytes())
    return doc, buffers


def accessor(doc: dict, buffers: list[bytes], index: int, where: str) -> np.ndarray:
    """Accessor `index` as an array (count, components)."""
    acc = doc["accessors"][index]
    if "sparse" in acc:
        raise InputError(f"{where}: accessors[{index}] is sparse, which this reader does not read")
    dtype = np.dtype(DTYPES[acc["componentType"]])
    comps = gltf_check.TYPE_COMPONENTS[acc["type"]]
    count = acc["count"]
    if "bufferView" not in acc:
        return np.zeros((count, comps), dtype=dtype)
    view = doc["bufferViews"][acc["bufferView"]]
    data = buffers[view["buffer"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    size = dtype.itemsize * comps
    stride = view.get("byteStride", size)
    rows = np.ndarray((count, comps), dtype=dtype, buffer=data, offset=start, strides=(stride, dtype.itemsize))
    return np.array(rows)


def _local_matrix(node: dict) -> np.ndarray:
    if "matrix" in node:
        return np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major in the file
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3] = r * np.asarray(node.get("scale", [1.0, 1.0, 1.0]), dtype=np.float64)[None, :]
    m[:3, 3] = node.get("translation", [0.0, 0.0, 0.0])
    return m


def parts(path: Path) -> tuple[dict, list[Part]]:
    """(the glTF JSON, every triangle primitive of its default scene in world space)."""
    doc, buffers = read_document(path)
    nodes = doc.get("nodes", [])
    scenes = doc.get("scenes", [])
    roots = scenes[doc.get("scene", 0)]["nodes"] if scenes else [i for i in range(len(nodes))]
    out: list[Part] = []
    stack = [(r, np.eye(4)) for r in reversed(roots)]
    while stack:
        n, parent = stack.pop()
        node = nodes[n]
        world = parent @ _local_matrix(node)
        stack.extend((c, world) for c in reversed(node.get("children", [])))
        if "mesh" not in node:
            continue
        mesh = doc["meshes"][node["mesh"]]
        linear = world[:3, :3]
        det = np.linalg.det(linear)
        for k, prim in enumerate(mesh["primitives"]):
            where = f"{path}: meshes[{node['mesh']}].primitives[{k}]"
            if prim.get("mode", 4) != 4:
                raise InputError(f"{where}: mode {prim['mode']}: only triangle lists (mode 4) are read")
            attrs = prim["attributes"]
            p = accessor(doc, buffers, attrs["POSITION"], where).astype(np.float64)
            idx = (accessor(doc, buffers, prim["indices"], where).reshape(-1) if "indices" in prim
                   else np.arange(len(p)))
            idx = idx.astype(np.int64).reshape(-1, 3)
            if det < 0:
                idx = idx[:, ::-1]
            identity = np.array_equal(world, np.eye(4))
            positions = p if identity else p @ linear.T + world[:3, 3]
            normals = None
            if "NORMAL" in attrs:
                nrm = accessor(doc, buffers, attrs["NORMAL"], where).astype(np.float64)
                if not identity:
                    nrm = nrm @ np.linalg.inv(linear)
                    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
                normals = nrm.astype(np.float32)
            name = node.get("name") or mesh.get("name") or f"mesh_{node['mesh']}"
            out.append(Part(f"{name}" + (f"_{k}" if len(mesh["primitives"]) > 1 else ""),
                            positions.astype(np.float32), normals, idx, prim.get("material")))
    if not out:
        raise InputError(f"{path}: the default scene draws no mesh")
    return doc, out
