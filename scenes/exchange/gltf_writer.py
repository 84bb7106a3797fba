"""A minimal glTF 2.0 writer: triangle meshes (POSITION, NORMAL, uint32 indices), materials, one camera.

What the specification (Khronos glTF 2.0) requires and this writer does:
- `asset.version` "2.0" (5.7);
- every accessor's offset and its view's offset aligned to the component size; this writer aligns every
  view to 4 bytes (3.6.2.4 "Data alignment");
- POSITION accessors carry `min` and `max` (3.7.2.1: "POSITION ... MUST provide min and max");
- vertex views have `target` 34962 (ARRAY_BUFFER), index views 34963 (ELEMENT_ARRAY_BUFFER) and no
  byteStride (3.6.2.3);
- NORMAL is a unit float VEC3, indices UNSIGNED_INT (5125) SCALAR, mode 4 (TRIANGLES, the default);
- the camera node's `rotation` is a unit quaternion (x, y, z, w); a camera looks down its node's -Z with
  +Y up (3.10.2).
The arrays are written as they are given (float32 little-endian): no transform, no merging.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field

import numpy as np

ARRAY_BUFFER = 34962
ELEMENT_ARRAY_BUFFER = 34963
FLOAT = 5126
UNSIGNED_INT = 5125
TRIANGLES = 4


def _pad4(n: int) -> int:
    return (4 - n % 4) % 4


@dataclass
class Builder:
    """Collects buffer views, accessors, meshes, materials and nodes; `document(uri)` gives the JSON."""

    blob: bytearray = field(default_factory=bytearray)
    views: list = field(default_factory=list)
    accessors: list = field(default_factory=list)
    meshes: list = field(default_factory=list)
    materials: list = field(default_factory=list)
    nodes: list = field(default_factory=list)
    cameras: list = field(default_factory=list)
    extensions_used: set = field(default_factory=set)

    def _view(self, data: bytes, target: int) -> int:
        self.blob += b"\0" * _pad4(len(self.blob))
        self.views.append({"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data), "target": target})
        self.blob += data
        return len(self.views) - 1

    def _accessor(self, array: np.ndarray, kind: str, component: int, target: int, bounds: bool) -> int:
        view = self._view(array.tobytes(), target)
        acc = {"bufferView": view, "byteOffset": 0, "componentType": component,
               "count": int(array.shape[0]), "type": kind}
        if bounds:
            acc["min"] = [float(x) for x in array.min(axis=0)]
            acc["max"] = [float(x) for x in array.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def add_material(self, material: dict) -> int:
        self.materials.append(material)
        self.extensions_used |= set(material.get("extensions", {}))
        return len(self.materials) - 1

    def add_mesh(self, name: str, positions: np.ndarray, normals: np.ndarray, indices: np.ndarray,
                 material: int) -> int:
        """A mesh of one triangle primitive and a node (identity transform) drawing it; returns the node."""
        p = np.ascontiguousarray(positions, dtype="<f4")
        n = np.ascontiguousarray(normals, dtype="<f4")
        i = np.ascontiguousarray(np.asarray(indices).reshape(-1), dtype="<u4")
        attributes = {"POSITION": self._accessor(p, "VEC3", FLOAT, ARRAY_BUFFER, bounds=True),
                      "NORMAL": self._accessor(n, "VEC3", FLOAT, ARRAY_BUFFER, bounds=False)}
        idx = self._accessor(i.reshape(-1, 1), "SCALAR", UNSIGNED_INT, ELEMENT_ARRAY_BUFFER, bounds=False)
        self.meshes.append({"name": name, "primitives": [{"attributes": attributes, "indices": idx,
                                                          "material": material, "mode": TRIANGLES}]})
        self.nodes.append({"name": name, "mesh": len(self.meshes) - 1})
        return len(self.nodes) - 1

    def add_camera(self, name: str, yfov: float, aspect: float, znear: float, zfar: float,
                   translation, rotation) -> int:
        self.cameras.append({"name": name, "type": "perspective",
                             "perspective": {"yfov": float(yfov), "aspectRatio": float(aspect),
                                             "znear": float(znear), "zfar": float(zfar)}})
        self.nodes.append({"name": name, "camera": len(self.cameras) - 1,
                           "translation": [float(x) for x in translation], "rotation": [float(x) for x in rotation]})
        return len(self.nodes) - 1

    def document(self, uri: str | None, generator: str = "iblcheck export") -> dict:
        """The glTF JSON; `uri` names the .bin file (None: the GLB's own BIN chunk)."""
        buffer = {"byteLength": len(self.blob) + _pad4(len(self.blob))}
        if uri is not None:
            buffer["uri"] = uri
        doc = {"asset": {"version": "2.0", "generator": generator},
               "scene": 0, "scenes": [{"nodes": list(range(len(self.nodes)))}], "nodes": self.nodes,
               "meshes": self.meshes, "materials": self.materials, "accessors": self.accessors,
               "bufferViews": self.views, "buffers": [buffer]}
        if self.cameras:
            doc["cameras"] = self.cameras
        if self.extensions_used:
            doc["extensionsUsed"] = sorted(self.extensions_used)
        return doc

    def binary(self) -> bytes:
        return bytes(self.blob) + b"\0" * _pad4(len(self.blob))

    def glb(self, generator: str = "iblcheck export") -> bytes:
        """The whole asset as one GLB (4.4): header, JSON chunk (space-padded), BIN chunk."""
        text = json_bytes(self.document(None, generator))
        text += b" " * _pad4(len(text))
        binary = self.binary()
        total = 12 + 8 + len(text) + 8 + len(binary)
        return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<II", len(text), 0x4E4F534A) + text
                + struct.pack("<II", len(binary), 0x004E4942) + binary)


def json_bytes(doc: dict) -> bytes:
    """JSON text (UTF-8); refuses NaN and Infinity, which JSON does not have."""
    return json.dumps(doc, indent=1, allow_nan=False).encode("utf-8")


def quaternion(m: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of a 3x3 rotation matrix (Shepperd's method: the largest of the four
    squared components is taken first, so no division by a small number)."""
    m = np.asarray(m, dtype=np.float64)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = 2.0 * np.sqrt(tr + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s]
    q = np.asarray(q)
    return q / np.linalg.norm(q)
