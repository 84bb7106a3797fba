"""glTF is read strictly: what the glTF 2.0 specification requires of a file's structure (the node
hierarchy is a forest, GLB lengths agree, URIs are relative paths or data: URIs inside the scene's
folder, buffers hold what they say) is refused with a reason naming the rule, and a valid file of the
same shape still loads (the control). Also an ASCII STL cut short."""

from __future__ import annotations

import base64
import copy
import json
import struct
from pathlib import Path

import numpy as np
import pytest

from scenes import MeshError
from scenes.geometry import meshes

TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()  # 36 bytes


def document(uri: str | None = None) -> dict:
    """A valid glTF of one triangle in one node; the buffer inline (data: URI) unless `uri` is given."""
    return {
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36,
                     "uri": uri or "data:application/octet-stream;base64," + base64.b64encode(TRIANGLE).decode()}],
    }


def glb(doc: dict, bin_chunk: bytes, length: int | None = None, version: int = 2) -> bytes:
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(bin_chunk), 0x004E4942) + bin_chunk
    total = 12 + len(body)
    return b"glTF" + struct.pack("<II", version, total if length is None else length) + body


def write(tmp_path: Path, doc: dict, name: str = "m.gltf") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def test_control_a_valid_gltf_loads_inline_from_a_file_and_as_glb(tmp_path):
    assert len(meshes.load_file(write(tmp_path, document())).indices) == 1
    (tmp_path / "tri.bin").write_bytes(TRIANGLE)
    assert len(meshes.load_file(write(tmp_path, document("tri.bin"), "f.gltf")).indices) == 1
    doc = document()
    del doc["buffers"][0]["uri"]
    (tmp_path / "m.glb").write_bytes(glb(doc, TRIANGLE))
    assert len(meshes.load_file(tmp_path / "m.glb").indices) == 1


def test_control_the_packaged_glb_passes():
    assert len(meshes.pawn().indices) > 100


def with_nodes(nodes: list, roots: list) -> dict:
    doc = document()
    doc["nodes"] = nodes
    doc["scenes"] = [{"nodes": roots}]
    return doc


@pytest.mark.parametrize("nodes, roots, says", [
    ([{"mesh": 0, "children": [1]}, {"children": [0]}], [0], "own ancestor"),
    ([{"mesh": 0, "children": [0]}], [0], "its own child"),
    ([{"children": [2]}, {"children": [2]}, {"mesh": 0}], [0, 1], "two parents"),
    ([{"children": [1]}, {"mesh": 0}], [0, 1], "root nodes only"),
    ([{"mesh": 0, "children": [5]}], [0], "refers to no element"),
    ([{"children": [1]}, {"children": [2]}, {"children": [1], "mesh": 0}], [0], "two parents"),
    ([{"mesh": 0}, {"children": [2]}, {"children": [1]}], [0], "own ancestor"),  # a cycle no scene reaches
])
def test_node_hierarchy_must_be_a_forest(tmp_path, nodes, roots, says):
    with pytest.raises(MeshError, match=says):
        meshes.load_file(write(tmp_path, with_nodes(nodes, roots)))


@pytest.mark.parametrize("length, version, says", [
    (10**9, 2, "header says 1000000000 bytes"),
    (5, 2, "header says 5 bytes"),
    (None, 1, "GLB version 1"),
])
def test_glb_header_must_agree_with_the_file(tmp_path, length, version, says):
    doc = document()
    del doc["buffers"][0]["uri"]
    (tmp_path / "m.glb").write_bytes(glb(doc, TRIANGLE, length, version))
    with pytest.raises(MeshError, match=says):
        meshes.load_file(tmp_path / "m.glb")


def test_glb_chunk_past_the_end_and_unaligned(tmp_path):
    doc = document()
    del doc["buffers"][0]["uri"]
    data = bytearray(glb(doc, TRIANGLE))
    text_len = struct.unpack_from("<I", data, 12)[0]
    struct.pack_into("<I", data, 12 + 8 + text_len, 400)  # the BIN chunk claims 400 bytes
    (tmp_path / "a.glb").write_bytes(bytes(data))
    with pytest.raises(MeshError, match="runs past the end"):
        meshes.load_file(tmp_path / "a.glb")
    struct.pack_into("<I", data, 12 + 8 + text_len, 34)
    (tmp_path / "b.glb").write_bytes(bytes(data))
    with pytest.raises(MeshError, match="multiples of 4"):
        meshes.load_file(tmp_path / "b.glb")


@pytest.mark.parametrize("uri, says", [
    ("http://127.0.0.1:9/cube.bin", "nothing from a network"),
    ("file:///etc/cube.bin", "nothing from a network"),
    ("/tmp/cube.bin", "inside the glTF's folder"),
    ("../cube.bin", "inside the glTF's folder"),
    ("sub/../../cube.bin", "inside the glTF's folder"),
    ("sub\\cube.bin", "inside the glTF's folder"),
    ("data:application/octet-stream,AAAA", "must be base64"),
    ("data:application/octet-stream;base64,@@@@", "not valid base64"),
    ("missing.bin", "not there"),
])
def test_buffer_uris_stay_inside_the_folder(tmp_path, uri, says):
    scene_dir = tmp_path / "scene"
    scene_dir.mkdir()
    for where in (tmp_path, scene_dir):  # a file of the same base name is there: it must not be read
        (where / "cube.bin").write_bytes(TRIANGLE)
    with pytest.raises(MeshError, match=says):
        meshes.load_file(write(scene_dir, document(uri)))


def test_control_a_relative_uri_in_a_subfolder_loads(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "tri.bin").write_bytes(TRIANGLE)
    assert len(meshes.load_file(write(tmp_path, document("sub/tri.bin"))).indices) == 1


@pytest.mark.parametrize("edit, says", [
    (lambda d: d["buffers"][0].update(byteLength=40), "holds 36 bytes"),
    (lambda d: d["bufferViews"][0].update(byteOffset=8), "does not lie inside"),
    (lambda d: d["bufferViews"][0].update(buffer=3), "refers to no element"),
    (lambda d: d["accessors"][0].update(count=4), "needs 48 bytes"),
    (lambda d: d["accessors"][0].update(type="VEC9"), "no valid componentType"),
])
def test_buffers_views_and_accessors_fit(tmp_path, edit, says):
    doc = copy.deepcopy(document())
    edit(doc)
    with pytest.raises(MeshError, match=says):
        meshes.load_file(write(tmp_path, doc))


def test_ascii_stl_without_endsolid_says_so(tmp_path):
    facet = "facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 0 1 0\n endloop\nendfacet\n"
    (tmp_path / "cut.stl").write_text("solid t\n" + facet)
    with pytest.raises(MeshError, match="endsolid"):
        meshes.load_file(tmp_path / "cut.stl")
    (tmp_path / "ok.stl").write_text("solid t\n" + facet + "endsolid t\n")  # the control
    assert len(meshes.load_file(tmp_path / "ok.stl").indices) == 1


def test_a_symbolic_link_out_of_the_folder_is_refused(tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "tri.bin").write_bytes(TRIANGLE)
    scene_dir = tmp_path / "scene"
    scene_dir.mkdir()
    (scene_dir / "sub").symlink_to(outside)
    with pytest.raises(MeshError, match="leads outside"):
        meshes.load_file(write(scene_dir, document("sub/tri.bin")))
    (scene_dir / "inside").mkdir()  # the control: a real sub-folder
    (scene_dir / "inside" / "tri.bin").write_bytes(TRIANGLE)
    assert len(meshes.load_file(write(scene_dir, document("inside/tri.bin"), "ok.gltf")).indices) == 1
