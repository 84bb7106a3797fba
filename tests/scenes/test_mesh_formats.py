"""Mesh files through trimesh: OBJ, PLY, STL (binary and ASCII), OFF, GLB and glTF read the same
triangles; glTF node transforms are applied (positions, normals by the inverse transpose, winding
where a node mirrors); the face limit counts instances; broken files are refused in iblcheck's words.

Every file here is written by hand from its format's specification (not by trimesh's exporters), so a
reader and a writer cannot agree on the same mistake."""

from __future__ import annotations

import json
import struct
import warnings

import numpy as np
import pytest

from experiments.paper import e06_hostile_cases as hostile
from scenes import MeshError
from scenes.geometry import meshes

# a unit cube: 8 corners at +-0.5, 12 triangles wound counter-clockwise seen from outside
CORNERS = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
QUADS = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]  # -x +x -y +y -z +z
FACES = np.array([t for a, b, c, d in QUADS for t in ((a, b, c), (a, c, d))])


def test_the_cube_is_wound_outward():
    p = CORNERS[FACES]
    normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert (np.einsum("ij,ij->i", normals, p.mean(axis=1)) > 0).all()


def triangles(m: meshes.Mesh) -> np.ndarray:
    """The mesh's triangles as corner positions, each rotated to start at its smallest corner (so the
    winding is kept) and sorted: equal for equal triangle sets, whatever the vertex numbering."""
    tris = m.positions[m.indices].astype(np.float64)
    rolls = [min(range(3), key=lambda r, t=t: tuple(t[r])) for t in tris]
    tris = np.stack([np.roll(t, -r, axis=0) for t, r in zip(tris, rolls, strict=True)]).reshape(-1, 9)
    return tris[np.lexsort(tris.T[::-1])]


# --------------------------------------------------------------------------- writers, by the specifications


def obj_text(p=CORNERS, f=FACES) -> str:
    return "".join(f"v {x} {y} {z}\n" for x, y, z in p) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f)


def stl_binary(p=CORNERS, f=FACES) -> bytes:
    out = b"iblcheck test cube".ljust(80, b"\0") + struct.pack("<I", len(f))
    for tri in f:
        out += struct.pack("<12fH", 0.0, 0.0, 0.0, *p[tri].ravel(), 0)  # zero facet normals: many writers do
    return out


def stl_ascii(p=CORNERS, f=FACES) -> str:
    facets = "".join("facet normal 0 0 0\n outer loop\n" + "".join(f"  vertex {x} {y} {z}\n" for x, y, z in p[tri])
                     + " endloop\nendfacet\n" for tri in f)
    return f"solid cube\n{facets}endsolid cube\n"


def off_text(p=CORNERS, f=FACES) -> str:
    return (f"OFF\n# a comment\n{len(p)} {len(f)} 0\n" + "".join(f"{x} {y} {z}\n" for x, y, z in p)
            + "".join(f"3 {a} {b} {c}\n" for a, b, c in f))


def ply_text(p=CORNERS, f=FACES) -> str:
    head = (f"ply\nformat ascii 1.0\nelement vertex {len(p)}\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    return head + "".join(f"{x} {y} {z}\n" for x, y, z in p) + "".join(f"3 {a} {b} {c}\n" for a, b, c in f)


def gltf_parts(nodes: list[dict], p=CORNERS, f=FACES, normals=None, scene_nodes=(0,)) -> tuple[dict, bytes]:
    """(glTF JSON, binary buffer) of one mesh (float32 POSITION, optional NORMAL, uint32 indices) and
    the given node hierarchy (nodes refer to mesh 0 with "mesh": 0)."""
    pos = np.asarray(p, "<f4").tobytes()
    blobs = [pos] + ([np.asarray(normals, "<f4").tobytes()] if normals is not None else [])
    blobs.append(np.asarray(f, "<u4").tobytes())
    views, offset = [], 0
    for blob in blobs:
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(blob)})
        offset += len(blob)
    accessors = [{"bufferView": 0, "componentType": 5126, "count": len(p), "type": "VEC3",
                  "min": np.min(p, axis=0).tolist(), "max": np.max(p, axis=0).tolist()}]
    attributes = {"POSITION": 0}
    if normals is not None:
        accessors.append({"bufferView": 1, "componentType": 5126, "count": len(p), "type": "VEC3"})
        attributes["NORMAL"] = 1
    accessors.append({"bufferView": len(blobs) - 1, "componentType": 5125, "count": int(np.size(f)),
                      "type": "SCALAR"})
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(scene_nodes)}], "nodes": nodes,
           "meshes": [{"primitives": [{"attributes": attributes, "indices": len(accessors) - 1, "mode": 4}]}],
           "accessors": accessors, "bufferViews": views, "buffers": [{"byteLength": offset}]}
    return doc, b"".join(blobs)


def glb(nodes: list[dict], **kw) -> bytes:
    doc, binary = gltf_parts(nodes, **kw)
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(binary), 0x004E4942) + binary
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


# --------------------------------------------------------------------------- one cube, every format


@pytest.mark.parametrize(("name", "data"), [
    ("cube.ply", ply_text().encode()), ("cube.stl", stl_binary()), ("ascii.stl", stl_ascii().encode()),
    ("cube.off", off_text().encode()), ("cube.glb", glb([{"mesh": 0}])),
])
def test_every_format_reads_the_triangles_of_the_obj(tmp_path, name, data):
    (tmp_path / "cube.obj").write_text(obj_text())
    (tmp_path / name).write_bytes(data)
    want = meshes.load_file(tmp_path / "cube.obj", "flat")
    got = meshes.load_file(tmp_path / name, "flat")
    assert got.n_triangles == 12 and got.closed and got.convex
    np.testing.assert_array_equal(triangles(got), triangles(want))
    np.testing.assert_array_equal(triangles(want), triangles(meshes.make_mesh("cube", CORNERS, FACES, shading="flat")))


def test_stl_has_no_vertex_normals_and_smooths_across_its_unshared_corners(tmp_path):
    """STL stores three corners per facet and no vertex normals: "auto" is flat (its facets); "smooth"
    welds the corners by position (a cube of 8 corners, diagonal normals); "file" is refused."""
    (tmp_path / "cube.stl").write_bytes(stl_binary())
    m = meshes.load_file(tmp_path / "cube.stl")
    assert len(m.positions) == 36
    np.testing.assert_allclose(m.normals[m.indices[:, 0]], m.face_normals() / np.linalg.norm(
        m.face_normals(), axis=1, keepdims=True), atol=1e-6)
    m = meshes.load_file(tmp_path / "cube.stl", "smooth")
    assert len(m.positions) == 8
    np.testing.assert_allclose(m.normals, np.sign(m.positions) / np.sqrt(3), atol=1e-6)
    with pytest.raises(MeshError, match=r'cube\.stl: normals = "file", but it has no vertex normals'):
        meshes.load_file(tmp_path / "cube.stl", "file")


def test_glb_without_normals_is_flat_as_gltf_says(tmp_path):
    """glTF 2.0: "When normals are not specified, client implementations MUST calculate flat normals"."""
    (tmp_path / "bare.glb").write_bytes(glb([{"mesh": 0}]))
    m = meshes.load_file(tmp_path / "bare.glb")
    assert len(m.positions) == 36 and (np.abs(m.normals).max(axis=1) > 1 - 1e-6).all()
    assert len(meshes.load_file(tmp_path / "bare.glb", "smooth").positions) == 8
    (tmp_path / "bare.off").write_text(off_text())  # OFF (and OBJ, PLY) without normals: smooth
    assert len(meshes.load_file(tmp_path / "bare.off").positions) == 8


def test_ply_and_glb_normals_are_the_files(tmp_path):
    n = np.sign(CORNERS) / np.sqrt(3)
    (tmp_path / "n.glb").write_bytes(glb([{"mesh": 0}], normals=n))
    np.testing.assert_allclose(meshes.load_file(tmp_path / "n.glb").normals[np.argsort(
        np.lexsort(CORNERS.T))], n[np.argsort(np.lexsort(CORNERS.T))], atol=1e-6)
    m = meshes.load_file(tmp_path / "n.glb", "file")
    np.testing.assert_allclose(m.normals, np.sign(m.positions) / np.sqrt(3), atol=1e-6)
    head = ply_text().replace("property float z\n", "property float z\nproperty float nx\nproperty float ny\n"
                              "property float nz\n")
    lines = head.splitlines()
    start = lines.index("end_header") + 1
    for k in range(8):
        lines[start + k] += " {} {} {}".format(*(-n[k]))  # inward: flipped, and said
    (tmp_path / "n.ply").write_text("\n".join(lines) + "\n")
    with pytest.warns(meshes.MeshWarning, match=r"n\.ply: 8 vertex normals .*\(inward\)"):
        m = meshes.load_file(tmp_path / "n.ply", "file")
    np.testing.assert_allclose(m.normals, np.sign(m.positions) / np.sqrt(3), atol=1e-6)


# --------------------------------------------------------------------------- glTF node transforms


def quat_y(deg: float) -> list[float]:
    h = np.radians(deg) / 2
    return [0.0, float(np.sin(h)), 0.0, float(np.cos(h))]  # glTF order: x, y, z, w


def test_glb_node_translation_scale_and_rotation_compose(tmp_path):
    """Parent: translate (1, 2, 3), scale 2; child: 90 degrees about +y, holding the mesh. A point p of
    the mesh lands at (1, 2, 3) + 2 R p with R p = (p_z, p_y, -p_x); a normal n at R n."""
    n = np.sign(CORNERS) / np.sqrt(3)
    nodes = [{"translation": [1.0, 2.0, 3.0], "scale": [2.0, 2.0, 2.0], "children": [1]},
             {"rotation": quat_y(90.0), "mesh": 0}]
    (tmp_path / "t.glb").write_bytes(glb(nodes, normals=n))
    m = meshes.load_file(tmp_path / "t.glb")

    def rotate(v):
        return np.stack([v[:, 2], v[:, 1], -v[:, 0]], axis=1)

    want = meshes.make_mesh("want", np.array([1.0, 2.0, 3.0]) + 2 * rotate(CORNERS), FACES, normals=rotate(n))
    np.testing.assert_allclose(triangles(m), triangles(want), atol=1e-6)
    np.testing.assert_allclose(m.positions.mean(axis=0), [1.0, 2.0, 3.0], atol=1e-6)
    np.testing.assert_allclose(np.ptp(m.positions, axis=0), [2.0, 2.0, 2.0], atol=1e-6)
    np.testing.assert_allclose(m.normals, np.sign(m.positions - [1.0, 2.0, 3.0]) / np.sqrt(3), atol=1e-6)


def test_glb_matrix_nodes_and_instances(tmp_path):
    """A node given as a column-major matrix, and the mesh instanced by two nodes: both copies."""
    matrix = np.eye(4)
    matrix[:3, 3] = [0.0, 0.0, -5.0]
    nodes = [{"matrix": matrix.T.ravel().tolist(), "mesh": 0}, {"translation": [3.0, 0.0, 0.0], "mesh": 0}]
    (tmp_path / "two.glb").write_bytes(glb(nodes, scene_nodes=(0, 1)))
    m = meshes.load_file(tmp_path / "two.glb", "flat")
    assert m.n_triangles == 24 and not m.convex
    right = m.positions[:, 0] > 1.5  # the instance at x = 3
    assert right.sum() == 36  # flat: 3 vertices per triangle, 12 triangles per instance
    np.testing.assert_allclose(m.positions[right].mean(axis=0), [3.0, 0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(m.positions[~right].mean(axis=0), [0.0, 0.0, -5.0], atol=1e-6)


def test_a_mirroring_node_keeps_faces_and_normals_outward(tmp_path):
    """scale (-1, 1, 1) mirrors: the winding must be reversed and the normals mirrored, or the cube
    would be inside out (one-sided materials would show nothing)."""
    n = np.sign(CORNERS) / np.sqrt(3)
    off = [[2.0, 0.0, 0.0]]
    (tmp_path / "m.glb").write_bytes(glb([{"scale": [-1.0, 1.0, 1.0], "translation": off[0], "mesh": 0}], normals=n))
    with warnings.catch_warnings():
        warnings.simplefilter("error", meshes.MeshWarning)  # no "inward" repair needed
        m = meshes.load_file(tmp_path / "m.glb")
    p = m.positions.astype(np.float64) - off
    fn = m.face_normals()
    assert (np.einsum("ij,ij->i", fn, p[m.indices].mean(axis=1)) > 0).all()
    np.testing.assert_allclose(m.normals, np.sign(p) / np.sqrt(3), atol=1e-6)


def test_non_uniform_scale_transforms_normals_by_the_inverse_transpose(tmp_path):
    """A corner normal (1, 1, 1)/sqrt 3 under scale (1, 3, 1) becomes (1, 1/3, 1), normalised."""
    n = np.sign(CORNERS) / np.sqrt(3)
    (tmp_path / "s.glb").write_bytes(glb([{"scale": [1.0, 3.0, 1.0], "mesh": 0}], normals=n))
    m = meshes.load_file(tmp_path / "s.glb", "file")
    want = np.sign(m.positions) * [1.0, 1 / 3, 1.0]
    np.testing.assert_allclose(m.normals, want / np.linalg.norm(want, axis=1, keepdims=True), atol=1e-6)
    np.testing.assert_allclose(np.ptp(m.positions, axis=0), [1.0, 3.0, 1.0], atol=1e-6)


def test_gltf_with_an_external_buffer(tmp_path):
    doc, binary = gltf_parts([{"translation": [0.0, 1.0, 0.0], "mesh": 0}])
    doc["buffers"][0]["uri"] = "cube.bin"
    (tmp_path / "cube.bin").write_bytes(binary)
    (tmp_path / "cube.gltf").write_text(json.dumps(doc))
    m = meshes.load_file(tmp_path / "cube.gltf", "flat")
    assert m.n_triangles == 12
    np.testing.assert_allclose(m.positions.mean(axis=0), [0.0, 1.0, 0.0], atol=1e-6)


def test_a_singular_node_is_refused(tmp_path):
    (tmp_path / "z.glb").write_bytes(glb([{"scale": [1.0, 0.0, 1.0], "mesh": 0}]))
    with pytest.raises(MeshError, match=r"z\.glb: node .* singular"):
        meshes.load_file(tmp_path / "z.glb")


# --------------------------------------------------------------------------- limits and broken files


def test_the_face_limit_counts_instances_and_stl_headers(tmp_path, monkeypatch):
    monkeypatch.setattr(meshes, "MAX_TRIANGLES", 20)
    nodes = [{"translation": [float(k), 0.0, 0.0], "mesh": 0} for k in range(3)]
    (tmp_path / "many.glb").write_bytes(glb(nodes, scene_nodes=(0, 1, 2)))
    with pytest.raises(MeshError, match=r"many\.glb: 36 triangles, more than the limit of 20"):
        meshes.load_file(tmp_path / "many.glb")
    big = stl_binary()[:80] + struct.pack("<I", 21) + stl_binary()[84:] + stl_binary()[84:84 + 9 * 50]
    (tmp_path / "big.stl").write_bytes(big)
    with pytest.raises(MeshError, match=r"big\.stl: 21 triangles, more than the limit of 20"):
        meshes.load_file(tmp_path / "big.stl")


@pytest.mark.parametrize(("name", "data"), [
    ("nan.stl", stl_binary(np.where(CORNERS == 0.5, np.nan, CORNERS))),
    ("nan.off", off_text(np.where(CORNERS == 0.5, np.nan, CORNERS)).encode()),
    ("nan.glb", glb([{"mesh": 0}], p=np.where(CORNERS == 0.5, np.nan, CORNERS))),
    ("nan.obj", obj_text(np.where(CORNERS == 0.5, np.nan, CORNERS)).encode()),
    ("inf.ply", ply_text(np.where(CORNERS == 0.5, np.inf, CORNERS)).encode()),
])
def test_non_finite_vertices_are_refused_in_every_format(tmp_path, name, data):
    (tmp_path / name).write_bytes(data)
    with pytest.raises(MeshError, match=rf"{name.replace('.', '[.]')}: vertex positions contain NaN or Inf"):
        meshes.load_file(tmp_path / name)


BROKEN = [
    ("off face past the end", "x.off", off_text().replace("3 0 1 3\n", "3 0 1 9\n", 1).encode()),
    ("off face of 2 corners", "x.off", off_text().replace("3 0 1 3\n", "2 0 1\n", 1).encode()),
    ("off without a header", "x.off", off_text().replace("OFF\n", "").encode()),
    ("off fractional index", "x.off", off_text().replace("3 0 1 3\n", "3 0 1.5 3\n", 1).encode()),
    ("off with a word", "x.off", off_text().replace("-0.5", "minus", 1).encode()),
    ("stl ascii facet of 2 vertices", "x.stl", stl_ascii().replace("  vertex 0.5 0.5 0.5\n", "", 1).encode()),
    ("stl ascii word", "x.stl", stl_ascii().replace("vertex -0.5", "vertex minus", 1).encode()),
    ("glb bad magic", "x.glb", b"glTX" + glb([{"mesh": 0}])[4:]),
    ("glb index past the end", "x.glb", glb([{"mesh": 0}], f=np.where(FACES == 7, 70, FACES))),
    ("glb node without a mesh", "x.glb", glb([{"translation": [0.0, 0.0, 0.0]}])),
    ("glb json garbage", "x.glb", glb([{"mesh": 0}]).replace(b'"asset"', b'"asset\x00', 1)),
    ("gltf missing buffer", "x.gltf", json.dumps(dict(gltf_parts([{"mesh": 0}])[0], buffers=[
        {"byteLength": 400, "uri": "nowhere.bin"}])).encode()),
    ("empty file", "x.stl", b""), ("empty glb", "x.glb", b""), ("empty off", "x.off", b""),
]


@pytest.mark.parametrize("index", range(len(BROKEN)), ids=lambda i: BROKEN[i][0])
def test_broken_files_are_refused_in_iblcheck_words(tmp_path, index):
    label, name, data = BROKEN[index]
    (tmp_path / name).write_bytes(data)
    assert hostile.mesh_outcome(tmp_path / name) == "refused", label


@pytest.mark.parametrize(("name", "data"), [
    ("cube.stl", stl_binary()), ("ascii.stl", stl_ascii().encode()), ("cube.off", off_text().encode()),
    ("cube.glb", glb([{"rotation": quat_y(30.0), "mesh": 0}], normals=np.sign(CORNERS) / np.sqrt(3))),
])
def test_cut_files_are_refused_or_read_never_misread_in_python_words(tmp_path, name, data):
    """Every truncation: refused naming the file, or (where the cut leaves a whole file) read with no
    more triangles than the cube has and none of them outside it."""
    for cut in hostile.truncations(data, 32):
        path = tmp_path / name
        path.write_bytes(cut)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", meshes.MeshWarning)
            outcome = hostile.mesh_outcome(path)
        assert outcome in ("refused", "loaded"), (name, len(cut), outcome)
        if outcome == "loaded":
            m = meshes.load_file(path)
            assert m.n_triangles <= 12 and np.abs(m.positions).max() <= 0.5 * np.sqrt(2) + 1e-6, (name, len(cut))
