"""Builtin meshes and mesh files: closed where they should be, unit outward normals, proportions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scenes import MeshError
from scenes.geometry import meshes

DATA = Path(__file__).resolve().parents[2] / "scenes" / "data" / "meshes"


@pytest.mark.parametrize("name,closed,convex", [
    ("sphere", True, True), ("torus", True, False), ("bowl", True, False),
    ("plane", False, True), ("teapot", False, False), ("pawn", True, False), ("rook", True, False),
])
def test_topology_and_convexity(name, closed, convex):
    m = meshes.builtin(name)
    assert m.closed is closed
    assert m.convex is convex


@pytest.mark.parametrize("name", list(meshes.BUILTIN_MESHES))
def test_unit_normals_agree_with_winding_and_fit_unit_sphere(name):
    m = meshes.builtin(name)
    np.testing.assert_allclose(np.linalg.norm(m.normals, axis=1), 1.0, atol=1e-6)
    fn = m.face_normals()
    assert (np.einsum("ij,ij->i", fn, m.normals[m.indices].sum(axis=1)) > 0).all()
    assert m.bounding_radius() <= 1.0 + 1e-6
    centre = (m.positions.min(axis=0) + m.positions.max(axis=0)) / 2
    np.testing.assert_allclose(centre, 0.0, atol=1e-6)


@pytest.mark.parametrize("name,volume", [
    ("sphere", 4 / 3 * np.pi),  # tessellation loses a little: within 0.2 %
    ("torus", 2 * np.pi**2 * 0.7 * 0.3**2),
    ("bowl", 2 / 3 * np.pi * (0.85**3 - 0.75**3)),
])
def test_closed_meshes_enclose_the_analytic_volume_outward(name, volume):
    m = meshes.builtin(name)
    p = m.positions.astype(np.float64)
    signed = np.einsum("ij,ij->", p[m.indices[:, 0]], m.face_normals()) / 6.0  # divergence theorem
    assert signed == pytest.approx(volume, rel=5e-3)  # positive: faces wind outward


def test_sphere_normals_are_outward_positions():
    m = meshes.sphere(32)
    np.testing.assert_allclose(m.normals, m.positions, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(m.positions, axis=1), 1.0, atol=1e-6)


def test_teapot_proportions_and_outward_body():
    ctrl, patches = meshes._teapot_patches()
    # independent bounds in Newell's z-up frame: patch corners lie on the surface, and every
    # Bezier patch lies in the convex hull of its control points
    corners = ctrl[patches[:, [0, 0, 3, 3], [0, 3, 0, 3]].ravel()]
    hull = ctrl[patches.ravel()]
    m = meshes.teapot(16)
    ext = np.ptp(m.positions.astype(np.float64), axis=0)  # (x, y up, z) after the frame change
    width, height, depth = ext
    lo_w, hi_w = np.ptp(corners[:, 0]), np.ptp(hull[:, 0])
    # height 3.15 and depth 4.0 are both reached at patch corners (lid knob, body at z = 0.9)
    assert height / depth == pytest.approx(3.15 / 4.0, rel=1e-3)
    assert lo_w / 4.0 * 0.999 <= width / depth <= hi_w / 4.0 * 1.001  # Newell's depth is 4.0
    # body vertices away from spout and handle: normals point away from the vertical axis
    p, n = m.positions.astype(np.float64), m.normals.astype(np.float64)
    radial = p[:, [0, 2]]
    r = np.linalg.norm(radial, axis=1)
    body = (np.abs(p[:, 0]) < 0.3 * r) & (r > 0.55) & (np.abs(p[:, 1] - p[:, 1].min() - 0.3 * height) < 0.1 * height)
    assert body.sum() > 10
    assert (np.einsum("ij,ij->i", n[body][:, [0, 2]], radial[body] / r[body, None]) > 0.5).all()


def test_obj_with_and_without_normals(tmp_path):
    text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    (tmp_path / "tet.obj").write_text(text)
    m = meshes.load_file(tmp_path / "tet.obj")
    assert m.n_triangles == 4 and m.closed and m.convex
    np.testing.assert_allclose(np.linalg.norm(m.normals, axis=1), 1.0, atol=1e-6)
    # smooth normal of the apex (0, 0, 0): average of the three faces meeting there -> -(1,1,1)/sqrt3
    np.testing.assert_allclose(m.normals[0], -np.ones(3) / np.sqrt(3), atol=1e-6)
    (tmp_path / "n.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 2\nf 1//1 2//1 3//1\n")
    np.testing.assert_allclose(meshes.load_file(tmp_path / "n.obj").normals, [[0, 0, 1]] * 3)


@pytest.mark.parametrize("binary", [False, True])
def test_ply_ascii_and_binary(tmp_path, binary):
    verts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float32)
    head = ("ply\nformat {} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n")
    if binary:
        body = verts.astype("<f4").tobytes() + bytes([4]) + np.array([0, 1, 2, 3], "<i4").tobytes()
        data = head.format("binary_little_endian").encode() + body
    else:
        data = (head.format("ascii") + "".join(f"{a} {b} {c}\n" for a, b, c in verts) + "4 0 1 2 3\n").encode()
    (tmp_path / "q.ply").write_bytes(data)
    m = meshes.load_file(tmp_path / "q.ply")
    assert m.n_triangles == 2
    np.testing.assert_allclose(m.normals, [[0, 0, 1]] * 4, atol=1e-6)


def test_bad_mesh_files(tmp_path):
    (tmp_path / "e.obj").write_text("v 0 0 0\n")
    with pytest.raises(MeshError, match="no faces"):
        meshes.load_file(tmp_path / "e.obj")
    (tmp_path / "d.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    with pytest.raises(MeshError, match="degenerate"):
        meshes.load_file(tmp_path / "d.obj")
    (tmp_path / "r.obj").write_text("v 0 0 0\nf 1 2 3\n")
    with pytest.raises(MeshError, match="missing vertex"):
        meshes.load_file(tmp_path / "r.obj")


# --------------------------------------------------------------------------- shapes read from packaged files


@pytest.mark.parametrize(("name", "file"), [("pawn", "pawn.glb"), ("rook", "rook.stl")])
def test_packaged_shapes_are_their_files_and_their_stated_size(name, file):
    m = meshes.builtin(name)
    assert m.name == name and m.n_triangles == meshes.builtin_triangles(name)
    assert meshes.builtin(name, 200).n_triangles == m.n_triangles  # a file: resolution changes nothing
    np.testing.assert_array_equal(m.positions, meshes.load_file(DATA / file).positions)


def test_the_pawn_stands_up_with_its_files_normals():
    """pawn.glb is modelled z-up; its root node turns it y-up: the foot is at the bottom (the widest
    part, flat, facing down) and the head at the top; its NORMAL attribute has hard rims."""
    m = meshes.builtin("pawn")
    p, n = m.positions.astype(np.float64), m.normals.astype(np.float64)
    bottom = np.isclose(p[:, 1], p[:, 1].min(), atol=1e-5)
    assert np.linalg.norm(p[bottom][:, [0, 2]], axis=1).max() == pytest.approx(np.abs(p[:, [0, 2]]).max(), rel=1e-3)
    # a hard rim: at the foot's edge each position has two vertices, one facing down, one sideways
    down, sideways = n[bottom, 1] < -1 + 1e-6, np.abs(n[bottom, 1]) < 1e-3
    assert (down | sideways).all() and down.sum() > 64 and sideways.sum() == 64  # 64 sections
    top = np.argmax(p[:, 1])
    np.testing.assert_allclose(n[top], [0.0, 1.0, 0.0], atol=1e-3)
    assert p[:, 1].max() == pytest.approx(-p[:, 1].min(), abs=1e-5)  # centred


def test_make_models_writes_the_packaged_meshes(tmp_path):
    """The generator, run again, gives the triangles of the packaged files."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_models", DATA / "make_models.py")
    make_models = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_models)
    make_models.write_pawn(tmp_path / "pawn.glb")
    make_models.write_rook(tmp_path / "rook.stl")
    for file in ("pawn.glb", "rook.stl"):
        new, shipped = meshes.load_file(tmp_path / file), meshes.load_file(DATA / file)
        for key in ("positions", "normals", "indices"):
            np.testing.assert_array_equal(getattr(new, key), getattr(shipped, key))
