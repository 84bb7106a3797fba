"""Hard geometry, extreme sizes and exponents: finite output, correct values, clear refusals."""

from __future__ import annotations

import numpy as np
import pytest

import groundtruth
import realtime
from experiments.measure import metrics
from groundtruth.exact import quadrature, reflectance
from scenes import MeshError
from scenes.environment import envmap
from scenes.geometry import meshes
from tests.hard.common import run_cli, small_scene, write_tiny
from tests.helpers import unit_sphere_hits

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


@pytest.mark.gl
@pytest.mark.mitsuba
def test_camera_inside_the_object(tmp_path, monkeypatch):
    """Inside a closed sphere every pixel sees its inner, back-facing surface. The reference is exactly 0 (the
    sphere blocks all light), and so is the quadrature (whatever the back-face rule: F = 1 puts the lobe about
    the mirror direction below the horizon of n, and a one-sided material is black there). The real-time
    image, which ignores occlusion, follows the back-face rule of scenes/model/materials.py: only
    required finite and non-negative here."""
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    scene = small_scene("builtin:sphere-blend", **{"camera.origin": [0.0, 0.0, 0.3], "objects.0.scale": 2.0})
    ref, quad, rt = groundtruth.render(scene), quadrature.render(scene, subpixels=1), realtime.render(scene)
    assert ref.mask.all() and quad.mask.all() and rt.mask.all()
    assert (ref.rgb == 0).all() and (quad.rgb == 0).all()
    assert np.isfinite(rt.rgb).all() and rt.rgb.min() >= 0


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
    assert gate.returncode == 1 and "empty comparison: no pixel is covered" in gate.stdout


def numpy_diffuse(scene, level: int, normals: np.ndarray) -> np.ndarray:
    """kd / pi max(E(n), 0) with SH9 of mip level `level` of the numpy cube map (base 256, box filter)."""
    from realtime.engine import sh
    from scenes.environment import cubemap

    faces = cubemap.mip_chain(cubemap.from_equirect(scene.environment.radiance(), 256))[level]
    M = sh.irradiance_matrices(sh.project_cube(faces))
    return np.asarray(scene.objects[0].material.kd) / np.pi * np.maximum(sh.irradiance(M, normals), 0.0)


@pytest.mark.gl
@pytest.mark.parametrize(("face", "level"), [(1, 8), (2, 7), (4, 6)])  # level = log2(256 / face)
def test_tiny_cube_faces(face, level):
    """SH9 of 1 x 1 ... 4 x 4 faces: the image is kd / pi E(n) of that level's numpy SH9, within 1 %."""
    scene = small_scene("builtin:sphere-diffuse",
                        **{"realtime.face_size": face, "camera.width": 32, "camera.height": 32})
    r = realtime.render(scene)
    n, _, interior = unit_sphere_hits(scene.camera)
    sel = interior & r.mask
    assert sel.sum() > 200
    np.testing.assert_allclose(r.rgb[sel], numpy_diffuse(scene, level, n)[sel], rtol=0.01)


@pytest.mark.gl
def test_base_1024():
    """Face 1024 of base 1024 is level 0: a mirror (N = 1e6, bias 0) shows the map at the reflected direction,
    within the 2 % median that cube-map resampling allows (a wrong level blurs the probe by far more)."""
    scene = small_scene("builtin:sphere-phong", **{"realtime.base_size": 1024, "realtime.face_size": 1024,
                                             "objects.0.material.exponent": 1e6, "camera.width": 32,
                                             "camera.height": 32})
    r = realtime.render(scene)
    n, v, interior = unit_sphere_hits(scene.camera)
    expected = envmap.lookup(scene.environment.radiance(), 2 * np.sum(n * v, axis=-1, keepdims=True) * n - v)
    sel = interior & r.mask
    rel = np.abs(r.rgb[sel] - expected[sel]).mean(axis=-1) / (expected[sel].mean(axis=-1) + 1e-3)
    assert np.median(rel) < 0.02, np.median(rel)


@pytest.mark.gl
@pytest.mark.parametrize(("w", "h"), [(1, 1), (4096, 16)])
def test_extreme_image_sizes(w, h):
    """One pixel and a 256:1 strip: every pixel well inside the sphere is kd / pi E(n) (level 2), within 1 %."""
    scene = small_scene("builtin:sphere-diffuse", **{"camera.width": w, "camera.height": h})
    r = realtime.render(scene)
    assert r.rgb.shape == (h, w, 3) and np.isfinite(r.rgb).all()
    # the one pixel's centre ray meets the sphere's centre (n = +Z), far from any silhouette
    n, _, interior = unit_sphere_hits(scene.camera, margin_px=0.0 if w == 1 else 2.5)
    sel = interior & r.mask
    assert sel.sum() >= (1 if w == 1 else 30)
    np.testing.assert_allclose(r.rgb[sel], numpy_diffuse(scene, 2, n)[sel], rtol=0.01)


@pytest.mark.mitsuba
def test_one_pixel_reference(tmp_path, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    r = groundtruth.render(small_scene("builtin:sphere-diffuse", **{"camera.width": 1, "camera.height": 1}))
    assert r.rgb.shape == (1, 1, 3) and r.mask.all() and np.isfinite(r.rgb).all()


# McGuire's LOD at face 64 of base 256 (level 2): offset = max(0, log2(64 sqrt 3) - 0.5 log2(N + 1)), with
# log2(64 sqrt 3) = 6.792481: N = 0 -> 6.792 and N = 1 -> 6.292 (2 + offset > 8: clamped to the 1 x 1 level,
# the paper mapping's bias 6); N = 1e4 -> 6.792481 - 6.643928 = 0.148553 (bias 0.148553); N = 1e6 -> 0 (bias 0)
MCGUIRE_AS_PAPER_BIAS = {0.0: 6.0, 1.0: 6.0, 1e4: 0.148553, 1e6: 0.0}


@pytest.mark.gl
@pytest.mark.mitsuba
@pytest.mark.parametrize("exponent", [0.0, 1.0, 1e4, 1e6])
def test_extreme_exponents_in_all_three_renderers(tmp_path, monkeypatch, exponent):
    """Finite everywhere; in real time, McGuire's mapping equals the paper's at the bias worked out above
    (to 1e-4 relative: the bias is written to 6 digits, a LOD error of 1e-6 of a level)."""
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    images = {}
    for mapping, bias in (("paper", MCGUIRE_AS_PAPER_BIAS[exponent]), ("mcguire", 0.0)):
        scene = small_scene("builtin:sphere-phong", **{"objects.0.material.exponent": exponent,
                                                 "realtime.lod_mapping": mapping, "realtime.lod_bias": bias})
        images[mapping] = realtime.render(scene).rgb
        assert np.isfinite(images[mapping]).all()
    np.testing.assert_allclose(images["mcguire"], images["paper"], rtol=1e-4, atol=1e-6)
    for r in (groundtruth.render(scene), quadrature.render(scene, subpixels=1)):
        assert np.isfinite(r.rgb).all() and r.rgb.min() >= 0


@pytest.mark.gl
def test_lod_clamps_to_the_chain():
    """A bias far beyond the chain gives exactly the coarsest level's image, far below the finest's."""
    base = {"realtime.face_size": 64, "realtime.base_size": 64}
    render = {b: realtime.render(small_scene("builtin:sphere-phong", **base, **{"realtime.lod_bias": b}))
              for b in (6.0, 32.0, 0.0, -32.0)}
    coarsest, beyond, finest, below = (render[b].rgb for b in (6.0, 32.0, 0.0, -32.0))
    np.testing.assert_array_equal(beyond, coarsest)
    np.testing.assert_array_equal(below, finest)
    # and the ends are different images (a shader that ignores the bias would pass the two lines above):
    # the 1 x 1 level is one colour per face, the 64 x 64 level shows the probe; their pixels differ by
    # more than 10 % of the finest image's mean on at least a quarter of the covered pixels
    mask = render[0.0].mask
    diff = np.abs(coarsest - finest)[mask].max(axis=-1)
    assert np.mean(diff > 0.1 * finest[mask].mean()) > 0.25


@pytest.mark.parametrize("n_dot_v", [-1.0, -1e-3, 0.0])
def test_fresnel_at_and_beyond_grazing_is_one(n_dot_v):
    assert reflectance.schlick(0.04, np.array(n_dot_v)) == 1.0


@pytest.mark.gl
def test_silhouette_normals_of_a_coarse_sphere():
    """A 6 x 3 sphere in a constant environment of radiance 1: E = pi and L_g = 1, so every pixel whose
    interpolated normal faces the viewer is (1 - F) kd + F ks, F Schlick's at that normal, which the numpy
    raycast (same mesh, same vertex normals) finds independently; F runs from f0 to nearly 1 across the
    coarse facets. Tolerance 1e-4 (measured 8e-6). Where the interpolated normal has turned away from the
    viewer (n.v <= 0, a few silhouette pixels) the image is only required to be finite: what a back face
    shows is the back-face rule of scenes/model/materials.py, not this test's."""
    from groundtruth.exact import raycast

    kd, ks, f0 = 0.3, 0.9, 0.04
    scene = small_scene("builtin:sphere-blend", **{
        "objects.0.resolution": 6, "camera.width": 64, "camera.height": 64, "environment.map": "builtin:constant",
        "objects.0.material.kd": [kd] * 3, "objects.0.material.ks": [ks] * 3, "objects.0.material.f0": f0})
    r = realtime.render(scene)
    assert np.isfinite(r.rgb).all()
    hits = raycast.cast(scene, subpixels=1)
    n_dot_v = np.sum(hits.normal[..., 0, :] * -hits.direction[..., 0, :], axis=-1)
    F = f0 + (1 - f0) * (1 - np.clip(n_dot_v, 0.0, 1.0)) ** 5
    expected = (1 - F) * kd + F * ks
    sel = hits.hit[..., 0] & r.mask & (n_dot_v > 1e-3)
    assert sel.sum() > 2000 and F[sel].max() > 0.5  # grazing facets, not just the centre
    np.testing.assert_allclose(r.rgb[sel], np.repeat(expected[sel][:, None], 3, axis=1), atol=1e-4)


def test_metrics_of_an_empty_mask_via_cli_gate_table():
    from experiments.runs.gate import GateResult, evaluate, format_table

    failures = evaluate({"psnr": None}, {"min_psnr": 30.0})
    assert failures == ["psnr undefined (no covered pixels), required >= 30"]
    assert "FAIL" in format_table([GateResult("s", {"psnr": None}, {"min_psnr": 30.0}, failures)])
    assert metrics.psnr(np.zeros((2, 2, 3)), np.zeros((2, 2, 3)), np.zeros((2, 2), bool)) is None
