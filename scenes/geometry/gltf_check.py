"""What the glTF 2.0 specification requires of a file's structure, checked before trimesh reads it.

trimesh reads glTF leniently: it follows node cycles until it gives up or not at all, accepts a node with
two parents (drawing it twice), trusts a GLB header's length, and resolves a buffer `uri` by its base name
(`http://host/cube.bin` loads a local `cube.bin`). The checks here follow the specification (Khronos glTF
2.0, sections 3.5 "Nodes and hierarchy", 3.6 "Binary data storage", 4.4 "GLB file format") and the
rules of Khronos' glTF-Validator of the same names, and each refusal says which rule a file breaks:

- GLB (4.4): magic "glTF", version 2, the header's `length` equal to the file's length, a JSON chunk
  first, every chunk inside the file, chunk lengths multiples of 4, at most one BIN chunk after it.
- Node hierarchy (3.5.3): "the node hierarchy MUST be a set of disjoint strict trees": no node is its
  own ancestor, no node has two parents, child indices exist, and a scene lists root nodes only.
- URIs (3.6.1.1, 2.8): a buffer or image `uri` is a `data:` URI or a relative path; iblcheck also
  requires that it stays inside the glTF's folder (no scheme, no absolute path, no `..` out of it).
- Buffers and views (3.6.1, 3.6.2): a buffer's data holds at least `byteLength` bytes, a buffer view
  lies inside its buffer, an accessor inside its view.
"""

from __future__ import annotations

import base64
import json
import struct
from pathlib import Path, PurePosixPath
from urllib.parse import unquote, urlparse

from scenes.storage.errors import MeshError

GLB_MAGIC = b"glTF"
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942
#: bytes per component of an accessor's componentType, and components per element of its type (3.6.2.2)
COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
TYPE_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def split_glb(path: Path, data: bytes) -> tuple[dict, bytes | None]:
    """(the JSON document, the BIN chunk or None) of a GLB file, its container checked (4.4)."""
    if len(data) < 12 or data[:4] != GLB_MAGIC:
        raise MeshError(f"{path}: no GLB header (a GLB file starts with 'glTF')")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise MeshError(f"{path}: GLB version {version}; iblcheck reads glTF 2.0 (version 2)")
    if length != len(data):
        raise MeshError(f"{path}: the GLB header says {length} bytes, the file has {len(data)}: cut short or padded")
    chunks = []
    offset = 12
    while offset < length:
        if offset + 8 > length:
            raise MeshError(f"{path}: a GLB chunk header at byte {offset} runs past the end of the file")
        size, kind = struct.unpack_from("<II", data, offset)
        if size % 4:
            raise MeshError(f"{path}: a GLB chunk of {size} bytes; chunk lengths must be multiples of 4")
        if offset + 8 + size > length:
            raise MeshError(f"{path}: a GLB chunk of {size} bytes at byte {offset} runs past the end of the file")
        chunks.append((kind, data[offset + 8:offset + 8 + size]))
        offset += 8 + size
    if not chunks or chunks[0][0] != CHUNK_JSON:
        raise MeshError(f"{path}: the first GLB chunk must be the JSON chunk")
    bins = [body for kind, body in chunks[1:] if kind == CHUNK_BIN]
    if len(bins) > 1:
        raise MeshError(f"{path}: {len(bins)} BIN chunks; a GLB holds at most one")
    return _json(path, chunks[0][1]), (bins[0] if bins else None)


def _json(path: Path, text: bytes) -> dict:
    try:
        doc = json.loads(text)
    except (ValueError, UnicodeDecodeError):
        raise MeshError(f"{path}: its JSON is malformed") from None
    if not isinstance(doc, dict):
        raise MeshError(f"{path}: its JSON is not an object")
    return doc


def _list(path: Path, doc: dict, key: str) -> list:
    value = doc.get(key, [])
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise MeshError(f"{path}: `{key}` must be a list of objects")
    return value


def _index(path: Path, value, count: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < count:
        raise MeshError(f"{path}: {what} = {value!r} refers to no element (there are {count})")
    return value


def check_hierarchy(path: Path, doc: dict) -> None:
    """The node hierarchy is a forest (3.5.3) and scenes list roots only."""
    nodes = _list(path, doc, "nodes")
    parent: dict[int, int] = {}
    for i, node in enumerate(nodes):
        children = node.get("children", [])
        if not isinstance(children, list):
            raise MeshError(f"{path}: nodes[{i}].children must be a list")
        for child in children:
            c = _index(path, child, len(nodes), f"nodes[{i}].children")
            if c == i:
                raise MeshError(f"{path}: nodes[{i}] is its own child; the node hierarchy must be a forest")
            if c in parent:
                raise MeshError(f"{path}: nodes[{c}] has two parents (nodes[{parent[c]}] and nodes[{i}]); "
                                "the node hierarchy must be a forest")
            parent[c] = i
    for start in range(len(nodes)):  # with one parent each, a cycle is a walk up that returns
        seen, node = {start}, start
        while node in parent:
            node = parent[node]
            if node in seen:
                raise MeshError(f"{path}: nodes[{start}] is its own ancestor (a cycle in the node hierarchy)")
            seen.add(node)
    for s, scene in enumerate(_list(path, doc, "scenes")):
        for root in scene.get("nodes", []):
            r = _index(path, root, len(nodes), f"scenes[{s}].nodes")
            if r in parent:
                raise MeshError(f"{path}: scenes[{s}] lists nodes[{r}], which is a child of nodes[{parent[r]}]; "
                                "a scene lists root nodes only")


def _relative_inside(path: Path, uri: str, what: str) -> Path:
    """The file a relative URI names, refused unless it stays inside the glTF's folder."""
    parsed = urlparse(uri)
    if parsed.scheme or parsed.netloc:
        raise MeshError(f"{path}: {what} = {uri[:80]!r}: only relative paths and data: URIs are read, "
                        "nothing from a network or another scheme")
    rel = PurePosixPath(unquote(parsed.path))
    if rel.is_absolute() or ".." in rel.parts or "\\" in uri:
        raise MeshError(f"{path}: {what} = {uri[:80]!r}: the path must stay inside the glTF's folder")
    target = path.parent.joinpath(*rel.parts)
    try:  # a symbolic link on the way may lead out of the folder: judge where the path really leads
        inside = target.resolve().is_relative_to(path.parent.resolve())
    except (OSError, RuntimeError):  # a link loop
        inside = False
    if not inside:
        raise MeshError(f"{path}: {what} = {uri[:80]!r}: the path leads outside the glTF's folder (a symbolic link)")
    return target


def _buffer_bytes(path: Path, buffer: dict, i: int, glb_bin: bytes | None) -> int:
    """How many bytes buffer i's data holds (read from its data: URI, file or the GLB's BIN chunk)."""
    uri = buffer.get("uri")
    if uri is None:
        if i != 0 or glb_bin is None:
            raise MeshError(f"{path}: buffers[{i}] has no uri and is not a GLB's BIN chunk")
        return len(glb_bin)
    if not isinstance(uri, str):
        raise MeshError(f"{path}: buffers[{i}].uri must be a string")
    if uri.startswith("data:"):
        head, _, payload = uri.partition(",")
        if not head.endswith(";base64"):
            raise MeshError(f"{path}: buffers[{i}].uri: a data: URI must be base64")
        try:
            return len(base64.b64decode(payload, validate=True))
        except ValueError:
            raise MeshError(f"{path}: buffers[{i}].uri: the data: URI is not valid base64") from None
    file = _relative_inside(path, uri, f"buffers[{i}].uri")
    try:
        return file.stat().st_size
    except OSError:
        raise MeshError(f"{path}: buffers[{i}].uri = {uri[:80]!r} names a file that is not there") from None


def check_data(path: Path, doc: dict, glb_bin: bytes | None) -> None:
    """URIs stay inside the folder, buffers hold their byteLength, views and accessors fit (3.6)."""
    sizes = []
    for i, buffer in enumerate(_list(path, doc, "buffers")):
        length = buffer.get("byteLength")
        if isinstance(length, bool) or not isinstance(length, int) or length < 1:
            raise MeshError(f"{path}: buffers[{i}].byteLength = {length!r}: a positive integer is required")
        have = _buffer_bytes(path, buffer, i, glb_bin)
        if have < length:
            raise MeshError(f"{path}: buffers[{i}] holds {have} bytes, its byteLength says {length}")
        sizes.append(length)
    for i, image in enumerate(_list(path, doc, "images")):
        uri = image.get("uri")
        if isinstance(uri, str) and not uri.startswith("data:"):
            _relative_inside(path, uri, f"images[{i}].uri")
    views = _list(path, doc, "bufferViews")
    for i, view in enumerate(views):
        b = _index(path, view.get("buffer"), len(sizes), f"bufferViews[{i}].buffer")
        offset, length = view.get("byteOffset", 0), view.get("byteLength")
        if not all(isinstance(v, int) and not isinstance(v, bool) for v in (offset, length)) or offset < 0 \
                or length < 1 or offset + length > sizes[b]:
            raise MeshError(f"{path}: bufferViews[{i}] (byteOffset {offset!r}, byteLength {length!r}) does not lie "
                            f"inside buffers[{b}] of {sizes[b]} bytes")
    for i, accessor in enumerate(_list(path, doc, "accessors")):
        if "bufferView" not in accessor:
            continue  # all zeros (3.6.2.1): nothing to read
        v = _index(path, accessor["bufferView"], len(views), f"accessors[{i}].bufferView")
        count, offset = accessor.get("count"), accessor.get("byteOffset", 0)
        size = COMPONENT_BYTES.get(accessor.get("componentType"), 0) * TYPE_COMPONENTS.get(accessor.get("type"), 0)
        if not size or not isinstance(count, int) or isinstance(count, bool) or count < 1:
            raise MeshError(f"{path}: accessors[{i}] has no valid componentType, type and count")
        stride = views[v].get("byteStride", size)
        need = offset + stride * (count - 1) + size
        if need > views[v]["byteLength"]:
            raise MeshError(f"{path}: accessors[{i}] needs {need} bytes of bufferViews[{v}], which has "
                            f"{views[v]['byteLength']}")


def check(path: Path, kind: str, data: bytes) -> None:
    """Refuse a .gltf or .glb file that breaks the specification's structural rules (MeshError)."""
    if kind == "glb":
        doc, glb_bin = split_glb(path, data)
    else:
        doc, glb_bin = _json(path, data), None
    check_hierarchy(path, doc)
    check_data(path, doc, glb_bin)
