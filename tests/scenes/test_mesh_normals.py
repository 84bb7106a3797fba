"""objects.normals ("auto", "file", "smooth", "flat") and objects.crease_deg: the per-vertex normals
both renderers draw, with expectations worked out by hand (a cube's corner and face directions, a
sphere's radial direction), and the scene keys' validation."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import scenes
from experiments.paper import e06_hostile_cases as hostile
from scenes import MeshError, SceneError
from scenes.geometry import meshes
from tests.helpers import sphere_scene_text, write_scene

AXES = np.concatenate([np.eye(3), -np.eye(3)])


@pytest.fixture
def cube_obj(tmp_path):
    """A unit cube as OBJ: 8 shared corners at +-0.5, 12 triangles wound outward, no normals."""
    path = tmp_path / "cube.obj"
    path.write_text(hostile.cube_obj(shared=True))
    return path


def is_axis(n: np.ndarray) -> np.ndarray:
    return np.isclose(np.abs(n).max(axis=1), 1.0, atol=1e-6) & np.isclose(np.abs(n).sum(axis=1), 1.0, atol=1e-6)


def face_unit_normals(m: meshes.Mesh) -> np.ndarray:
    fn = m.face_normals()
    return fn / np.linalg.norm(fn, axis=1, keepdims=True)


def test_the_cube_file_has_8_shared_corners_and_no_normals(cube_obj):
    with pytest.raises(MeshError, match=r'cube\.obj: normals = "file", but it has no vertex normals.*"smooth".*"flat"'):
        meshes.load_file(cube_obj, "file")


def test_smooth_cube_normals_point_along_the_diagonals(cube_obj):
    for normals in ("auto", "smooth"):  # auto: no file normals -> smooth, as before trimesh
        m = meshes.load_file(cube_obj, normals)
        assert len(m.positions) == 8 and m.n_triangles == 12
        # angle weighting: each corner sees 90 degrees of each of its 3 faces, however they are split
        np.testing.assert_allclose(m.normals, np.sign(m.positions) / np.sqrt(3), atol=1e-6)


def test_flat_cube_normals_are_the_face_axes(cube_obj):
    m = meshes.load_file(cube_obj, "flat")
    assert len(m.positions) == 36 and m.n_triangles == 12  # every triangle its own corners
    corner_normals = m.normals[m.indices]  # (12, 3, 3)
    assert is_axis(m.normals).all()
    np.testing.assert_allclose(corner_normals, np.repeat(face_unit_normals(m)[:, None], 3, axis=1), atol=1e-6)
    # the axis is the one the face is perpendicular to, pointing outward: +-0.5 on that axis
    centres = m.positions[m.indices].mean(axis=1)
    np.testing.assert_allclose(corner_normals[:, 0], np.round(centres * 2), atol=1e-6)
    assert m.closed and m.convex  # splitting vertices leaves the surface closed and convex


@pytest.mark.parametrize("crease", [0.0, 30.0, 60.0, 89.0])
def test_a_crease_below_90_degrees_splits_every_cube_edge(cube_obj, crease):
    m = meshes.load_file(cube_obj, "smooth", crease)
    assert len(m.positions) == 24  # each corner once per face: the two triangles of a face share it
    assert is_axis(m.normals).all()
    np.testing.assert_allclose(m.normals[m.indices], np.repeat(face_unit_normals(m)[:, None], 3, axis=1), atol=1e-6)


@pytest.mark.parametrize("crease", [91.0, 120.0, 180.0])
def test_a_crease_above_90_degrees_keeps_the_cube_smooth(cube_obj, crease):
    m = meshes.load_file(cube_obj, "smooth", crease)
    assert len(m.positions) == 8
    np.testing.assert_allclose(m.normals, np.sign(m.positions) / np.sqrt(3), atol=1e-6)


def test_a_crease_splits_only_the_sharp_edges():
    """A tent: two roof faces, each of two triangles, meeting along the ridge (z) with normals 60 degrees
    apart. Crease 45: the ridge is hard and each face flat; crease 90: one smooth ridge pointing up."""
    h = np.sqrt(3) / 2  # ridge at (0, 0.5, z), eaves at (+-h, 0, z): each roof normal leans 30 degrees from +y
    p = np.array([[0, 0.5, 0], [0, 0.5, 1], [h, 0, 0], [h, 0, 1], [-h, 0, 0], [-h, 0, 1]], float)
    idx = np.array([[0, 1, 3], [0, 3, 2], [0, 4, 5], [0, 5, 1]])
    right, left = np.array([0.5, h, 0.0]), np.array([-0.5, h, 0.0])
    hard = meshes.make_mesh("tent", p, idx, shading="smooth", crease_deg=45.0)
    assert len(hard.positions) == 8  # the 2 ridge vertices split in two, the 4 eave vertices are not shared
    for tri, want in zip(hard.indices, [right, right, left, left], strict=True):
        np.testing.assert_allclose(hard.normals[tri], np.tile(want, (3, 1)), atol=1e-6)
    soft = meshes.make_mesh("tent", p, idx, shading="smooth", crease_deg=90.0)
    assert len(soft.positions) == 6
    ridge = np.isclose(soft.positions[:, 1], 0.5)
    np.testing.assert_allclose(soft.normals[ridge], np.tile([0.0, 1.0, 0.0], (2, 1)), atol=1e-6)


def test_smooth_sphere_normals_are_radial():
    sphere = meshes.builtin("sphere", 32)
    m = meshes.shaded(sphere, "smooth")
    radial = m.positions / np.linalg.norm(m.positions, axis=1, keepdims=True)
    cos = np.einsum("ij,ij->i", m.normals.astype(np.float64), radial)
    assert np.degrees(np.arccos(np.clip(cos.min(), -1, 1))) < 0.5
    assert len(m.positions) == len(sphere.positions)  # nothing to split, nothing welded
    # a crease wider than any angle between neighbouring faces (about 6 degrees here) changes nothing
    creased = meshes.shaded(sphere, "smooth", 30.0)
    assert len(creased.positions) == len(m.positions)


def test_flat_sphere_faces_face_outward():
    m = meshes.shaded(meshes.builtin("sphere", 16), "flat")
    centres = m.positions[m.indices].mean(axis=1)
    centres /= np.linalg.norm(centres, axis=1, keepdims=True)
    np.testing.assert_allclose(m.normals[m.indices[:, 0]], face_unit_normals(m), atol=1e-6)
    assert (np.einsum("ij,ij->i", m.normals[m.indices[:, 0]], centres) > 0.98).all()


def test_auto_and_file_keep_the_builtin_analytic_normals():
    for name in meshes.BUILTIN_MESHES:
        base = meshes.builtin(name)
        assert meshes.shaded(base, "auto") is base and meshes.shaded(base, "file") is base


def test_smooth_welds_seams_that_share_a_position():
    """The bowl's flat rim has its own vertices (a crease at the rim): "smooth" welds them to the walls
    and averages across; a crease angle below the rim's 90 degrees brings the crease back."""
    bowl = meshes.builtin("bowl", 16)
    smooth = meshes.shaded(bowl, "smooth")
    assert len(smooth.positions) < len(bowl.positions)
    rim = np.isclose(smooth.positions[:, 1], bowl.positions[:, 1].max())
    assert rim.any() and (np.abs(smooth.normals[rim, 1]) < 0.99).all()  # no longer straight up
    creased = meshes.shaded(bowl, "smooth", 45.0)
    rim = np.isclose(creased.positions[:, 1], bowl.positions[:, 1].max())
    assert (creased.normals[rim, 1] > 1 - 1e-6).sum() >= rim.sum() // 2  # the rim's own copies point up


def test_inward_file_normals_are_still_flipped_and_said(tmp_path):
    text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 -1\nf 1//1 2//1 3//1\n"
    (tmp_path / "in.obj").write_text(text)
    for normals in ("auto", "file"):
        with pytest.warns(meshes.MeshWarning, match=r"in\.obj: 3 vertex normals .*\(inward\)"):
            m = meshes.load_file(tmp_path / "in.obj", normals)
        np.testing.assert_allclose(m.normals, [[0, 0, 1]] * 3)


def test_smooth_and_flat_ignore_the_file_normals(tmp_path):
    text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1 0 0\nf 1//1 2//1 3//1\n"
    (tmp_path / "tilted.obj").write_text(text)
    np.testing.assert_allclose(meshes.load_file(tmp_path / "tilted.obj").normals, [[1, 0, 0]] * 3)
    for normals in ("smooth", "flat"):
        np.testing.assert_allclose(meshes.load_file(tmp_path / "tilted.obj", normals).normals, [[0, 0, 1]] * 3)


# --------------------------------------------------------------------------- the scene keys


def scene_with(tmp_path, shape: str = "sphere", lines: str = "") -> str:
    text = sphere_scene_text("n", 'map = "builtin:constant"', '{ type = "diffuse" }', 16, shape=shape,
                             object_lines=lines)
    return str(write_scene(tmp_path, text))


def test_scene_objects_take_normals_and_crease(tmp_path, cube_obj):
    s = scenes.load(scene_with(tmp_path, "cube.obj", 'normals = "smooth"\ncrease_deg = 60.0'))
    assert s.objects[0].normals == "smooth" and s.objects[0].crease_deg == 60.0
    assert len(s.objects[0].mesh.positions) == 24 and is_axis(s.objects[0].mesh.normals).all()
    flat = scenes.load(scene_with(tmp_path, "sphere", 'normals = "flat"\nresolution = 8'))
    assert len(flat.objects[0].mesh.positions) == 3 * flat.objects[0].mesh.n_triangles
    default = scenes.load(scene_with(tmp_path))
    assert default.objects[0].normals == "auto" and default.objects[0].crease_deg is None
    same = meshes.builtin("sphere").transformed(1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # as before normals existed
    np.testing.assert_array_equal(default.objects[0].mesh.normals, same.normals)


def test_overrides_reach_the_normals(tmp_path, cube_obj):
    s = scenes.load(scene_with(tmp_path, "cube.obj")).with_overrides({"objects.0.normals": "flat"})
    assert len(s.objects[0].mesh.positions) == 36


@pytest.mark.parametrize(("lines", "words"), [
    ('normals = "faceted"', ["objects[0].normals", "'faceted'", '"auto", "file", "smooth", "flat"']),
    ('normals = "smooth"\ncrease_deg = 200.0', ["objects[0].crease_deg", "200", "[0, 180]"]),
    ('normals = "smooth"\ncrease_deg = -1.0', ["objects[0].crease_deg", "[0, 180]"]),
    ('normals = "smooth"\ncrease_deg = "sharp"', ["objects[0].crease_deg", "a number"]),
    ("crease_deg = 30.0", ["objects[0].crease_deg = 30.0", "objects[0].normals = 'auto'", '"smooth"']),
    ('normals = "flat"\ncrease_deg = 30.0', ["objects[0].crease_deg", "objects[0].normals = 'flat'"]),
])
def test_bad_normals_keys_name_the_file_the_key_and_the_range(tmp_path, lines, words):
    path = scene_with(tmp_path, "sphere", lines)
    with pytest.raises(SceneError) as err:
        scenes.load(path)
    message = str(err.value)
    assert message.startswith(path), message
    for word in words:
        assert word in message, (word, message)


def test_file_normals_asked_of_a_file_without_them_name_the_scene_and_the_file(tmp_path, cube_obj):
    path = scene_with(tmp_path, "cube.obj", 'normals = "file"')
    with pytest.raises(SceneError, match=r"scene\.toml: .*cube\.obj: normals = \"file\", but it has no vertex"):
        scenes.load(path)


@pytest.mark.parametrize("suffix", [".fbx", ".3ds", ".dae"])
def test_other_mesh_formats_are_refused_with_the_list(tmp_path, suffix):
    (tmp_path / f"m{suffix}").write_text("x")
    with pytest.raises(SceneError, match=r"objects\[0\]\.shape.*\.obj, \.ply, \.stl, \.off, \.glb, \.gltf"):
        scenes.load(scene_with(tmp_path, f"m{suffix}"))


@pytest.mark.mitsuba
def test_both_renderers_get_the_same_normals(tmp_path, mi, cube_obj):
    """The reference's mi.Mesh holds exactly the vertices, normals and faces the real-time side draws."""
    from groundtruth.pathtracer import mitsuba_scene

    s = scenes.load(scene_with(tmp_path, "cube.obj", 'normals = "smooth"\ncrease_deg = 45.0'))
    mesh = s.objects[0].mesh
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = mitsuba_scene.make_mesh(mi, "cube", mesh, mi.load_dict({"type": "diffuse"}))
    params = mi.traverse(out)
    np.testing.assert_array_equal(np.array(params["vertex_normals"]).reshape(-1, 3), mesh.normals)
    np.testing.assert_array_equal(np.array(params["vertex_positions"]).reshape(-1, 3), mesh.positions)
    np.testing.assert_array_equal(np.array(params["faces"]).reshape(-1, 3), mesh.indices)
