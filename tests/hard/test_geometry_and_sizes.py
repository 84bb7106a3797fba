"""Hard geometry, extreme sizes and exponents: finite output, correct values, clear refusals."""

from __future__ import annotations

import numpy as np
import pytest

import groundtruth
import realtime
import scenes
from experiments import metrics
from groundtruth import quadrature, reflectance
from scenes import MeshError, meshes
from tests.hard.common import run_cli, write_tiny

OBJ_QUAD = """v -0.5 -0.5 0
v 0.5 -0.5 0
v 0.5 0.5 0
v -0.5 0.5 0
v 0.0 0.0 0
{normals}
f 1{n1} 2{n2} 3{n3}
f 1{n1} 3{n3} 4{n4}
f 1 1 2
"""


def write_obj(path, normals: str = "", refs: tuple = ("", "", "", ""), degenerate: bool = True) -> str:
    text = OBJ_QUAD.format(normals=normals, n1=refs[0], n2=refs[1], n3=refs[2], n4=refs[3])
    path.write_text(text if degenerate else text.replace("f 1 1 2\n", ""))
    return str(path)


def test_degenerate_triangles_are_dropped(tmp_path):
    m = meshes.load_file(write_obj(tmp_path / "q.obj"))
    assert m.n_triangles == 2  # the zero-area face 1 1 2 is gone


def test_mesh_without_normals_gets_face_normals(tmp_path):
    m = meshes.load_file(write_obj(tmp_path / "q.obj"))
    np.testing.assert_allclose(m.normals[:4], np.tile([0, 0, 1], (4, 1)), atol=1e-6)


def test_zero_length_and_inward_normals_are_repaired(tmp_path):
    normals = "vn 0 0 0\nvn 0 0 -1\nvn 0 0 1\nvn 0 0 -1"
    with pytest.warns(meshes.MeshWarning, match=r"2 vertex normals .*\(inward\)"):
        m = meshes.load_file(write_obj(tmp_path / "q.obj", normals, ("//1", "//2", "//3", "//4"), degenerate=False))
    np.testing.assert_allclose(m.normals[:4], np.tile([0, 0, 1], (4, 1)), atol=1e-6)


def test_all_degenerate_mesh_is_refused(tmp_path):
    (tmp_path / "d.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    with pytest.raises(MeshError, match="d.obj.*degenerate"):
        meshes.load_file(tmp_path / "d.obj")


def small(name, **ov):
    base = {"camera.width": 24, "camera.height": 24, "realtime.timing_frames": 1, "realtime.warmup_frames": 0,
            "reference.spp": 8}
    return scenes.load(name).with_overrides({**base, **ov})


@pytest.mark.gl
@pytest.mark.mitsuba
def test_camera_inside_the_object_stays_finite(tmp_path, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    scene = small("builtin:sphere-blend", **{"camera.origin": [0.0, 0.0, 0.3], "objects.0.scale": 2.0})
    for r in (realtime.render(scene), groundtruth.render(scene), quadrature.render(scene, subpixels=1)):
        assert np.isfinite(r.rgb).all() and r.rgb.min() >= 0


@pytest.mark.gl
@pytest.mark.mitsuba
def test_object_outside_the_view_gives_an_empty_mask_and_a_clear_message(tmp_path, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    path = write_tiny(tmp_path, name="away", extra="")
    path.write_text(path.read_text().replace('shape = "sphere"', 'shape = "sphere"\ntranslate = [30.0, 0.0, 0.0]'))
    out = run_cli("compare", str(path), "--json", cache=tmp_path / "cache")
    assert out.returncode == 0, out.stderr
    assert "no pixel is covered" in out.stderr
    import json

    result = json.loads(out.stdout)
    assert result["pixels"] == 0 and result["psnr"] is None
    gate = run_cli("gate", str(path), "--min-psnr", "20", cache=tmp_path / "cache")
    assert gate.returncode == 1 and "undefined (no covered pixels)" in gate.stdout


@pytest.mark.gl
@pytest.mark.parametrize("face", [1, 2, 4])
def test_tiny_cube_faces(face):
    r = realtime.render(small("builtin:sphere-blend", **{"realtime.face_size": face}))
    assert np.isfinite(r.rgb).all() and r.meta["face_size"] == face and r.rgb[r.mask].min() > 0


@pytest.mark.gl
def test_base_1024():
    r = realtime.render(small("builtin:sphere-blend", **{"realtime.base_size": 1024, "realtime.face_size": 1024}))
    assert np.isfinite(r.rgb).all() and r.meta["level"] == 0


@pytest.mark.gl
@pytest.mark.parametrize(("w", "h"), [(1, 1), (4096, 16)])
def test_extreme_image_sizes(w, h):
    r = realtime.render(small("builtin:sphere-diffuse", **{"camera.width": w, "camera.height": h}))
    assert r.rgb.shape == (h, w, 3) and np.isfinite(r.rgb).all()


@pytest.mark.mitsuba
def test_one_pixel_reference(tmp_path, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    r = groundtruth.render(small("builtin:sphere-diffuse", **{"camera.width": 1, "camera.height": 1}))
    assert r.rgb.shape == (1, 1, 3) and r.mask.all() and np.isfinite(r.rgb).all()


@pytest.mark.gl
@pytest.mark.mitsuba
@pytest.mark.parametrize("exponent", [0.0, 1.0, 1e4, 1e6])
def test_extreme_exponents_in_all_three_renderers(tmp_path, monkeypatch, exponent):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    for mapping in ("paper", "mcguire"):
        scene = small("builtin:sphere-phong", **{"objects.0.material.exponent": exponent,
                                                 "realtime.lod_mapping": mapping})
        assert np.isfinite(realtime.render(scene).rgb).all()
    for r in (groundtruth.render(scene), quadrature.render(scene, subpixels=1)):
        assert np.isfinite(r.rgb).all() and r.rgb.min() >= 0


@pytest.mark.gl
def test_lod_clamps_to_the_chain():
    """A bias far beyond the chain gives exactly the coarsest level's image, far below the finest's."""
    base = {"realtime.face_size": 64, "realtime.base_size": 64}
    coarsest = realtime.render(small("builtin:sphere-phong", **base, **{"realtime.lod_bias": 6.0})).rgb
    beyond = realtime.render(small("builtin:sphere-phong", **base, **{"realtime.lod_bias": 32.0})).rgb
    finest = realtime.render(small("builtin:sphere-phong", **base, **{"realtime.lod_bias": 0.0})).rgb
    below = realtime.render(small("builtin:sphere-phong", **base, **{"realtime.lod_bias": -32.0})).rgb
    np.testing.assert_array_equal(beyond, coarsest)
    np.testing.assert_array_equal(below, finest)


@pytest.mark.parametrize("n_dot_v", [-1.0, -1e-3, 0.0])
def test_fresnel_at_and_beyond_grazing_is_one(n_dot_v):
    assert reflectance.schlick(0.04, np.array(n_dot_v)) == 1.0


@pytest.mark.gl
def test_silhouette_normals_of_a_coarse_sphere_stay_finite():
    """A 6 x 3 sphere: interpolated normals at the silhouette face away from the viewer (n.v < 0)."""
    r = realtime.render(small("builtin:sphere-blend", **{"objects.0.resolution": 6, "camera.width": 64,
                                                          "camera.height": 64}))
    assert np.isfinite(r.rgb).all() and r.rgb.min() >= 0


def test_metrics_of_an_empty_mask_via_cli_gate_table():
    from experiments.gate import GateResult, evaluate, format_table

    failures = evaluate({"psnr": None}, {"min_psnr": 30.0})
    assert failures == ["psnr undefined (no covered pixels), required >= 30"]
    assert "FAIL" in format_table([GateResult("s", {"psnr": None}, {"min_psnr": 30.0}, failures)])
    assert metrics.psnr(np.zeros((2, 2, 3)), np.zeros((2, 2, 3)), np.zeros((2, 2), bool)) is None
