"""`iblcheck export`: what an engine reads from the exported files, computed in numpy apart from the
exporter (tests/exchange/gltf_numpy.py), against iblcheck's own lookup, camera and meshes."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

import scenes
from scenes.environment import envmap
from scenes.exchange import export as export_module
from scenes.exchange import sidecar
from scenes.exchange.export import BIN, ENVIRONMENT, GLTF, export_scene
from scenes.storage import imageio
from scenes.storage.errors import InputError
from tests.exchange.gltf_numpy import camera_rays, centre_direction, read_gltf, rot_y, viewer_lookup

#: the builtin scenes, one with its own environment rotation (pawn-pbr: 60 degrees) and one turned here
CASES = {"spheres-pbr-grid": {}, "pawn-pbr": {}, "sphere-diffuse": {},
         "sphere-diffuse-turned": {"environment.rotation_deg": -35.0}}
#: RGBE keeps 8 mantissa bits of each texel's largest channel: rounding to nearest errs by at most 2^-8 of it
RGBE = 2.0 ** -8


def _scene(case: str):
    name = case.removesuffix("-turned")
    # a small, non-square image: the fov-axis control needs width != height
    return scenes.load(f"builtin:{name}").with_overrides({"camera.width": 48, "camera.height": 32, **CASES[case]})


@pytest.fixture(scope="module", params=list(CASES))
def exported(request, tmp_path_factory):
    scene = _scene(request.param)
    out = export_scene(scene, tmp_path_factory.mktemp("export") / "out")
    side = json.loads(out.sidecar.read_text())
    return scene, out, side, imageio.read_hdr(out.environment)


def _centre_errors(scene, vmap, side, quarter_turn=True, sign=1.0):
    """|viewer - iblcheck| / (2^-8 max channel) at 2000 random texel centres (<= 1 passes); plus 1e-6 of the
    map's mean, for texels near black whose neighbours are not (the directions agree to float rounding only)."""
    rng = np.random.default_rng(1)
    h, w = vmap.shape[:2]
    r, c = rng.integers(0, h, 2000), rng.integers(0, w, 2000)
    theta = side["environment"]["rotation_y_deg"]
    world = centre_direction(r, c, h, w) @ rot_y(theta).T  # the texel's direction, turned into the world
    env = scene.environment.radiance()
    expect = envmap.lookup(env, world, scene.environment.rotation_deg).astype(np.float64)
    got = viewer_lookup(vmap, world @ rot_y(-sign * theta).T, quarter_turn)  # R_y(-THETA) d, per the sidecar
    return np.abs(got - expect).max(axis=-1) / (RGBE * expect.max(axis=-1) + 1e-6 * float(env.mean()))


def test_environment_equals_iblcheck_at_texel_centres(exported):
    scene, _, side, vmap = exported
    assert vmap.shape == scene.environment.radiance().shape
    assert side["environment"]["intensity"] == 1.0
    assert _centre_errors(scene, vmap, side).max() <= 1.0 + 1e-6


def test_environment_negative_controls(exported):
    scene, _, side, vmap = exported
    assert np.median(_centre_errors(scene, vmap, side, quarter_turn=False)) > 1.0  # the map read without its turn
    if side["environment"]["rotation_y_deg"]:
        assert np.median(_centre_errors(scene, vmap, side, sign=-1.0)) > 1.0  # the rotation of the wrong sign


def test_environment_close_between_centres(exported):
    """Between texel centres the two interpolate their own samples: close in the mean, not equal."""
    scene, _, side, vmap = exported
    rng = np.random.default_rng(2)
    d = rng.normal(size=(20000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    expect = envmap.lookup(scene.environment.radiance(), d, scene.environment.rotation_deg).astype(np.float64)
    got = viewer_lookup(vmap, d @ rot_y(-side["environment"]["rotation_y_deg"]).T)
    rel = np.abs(got - expect).mean() / expect.mean()
    wrong = np.abs(viewer_lookup(vmap, d, quarter_turn=False) - expect).mean() / expect.mean()
    assert rel < 0.05
    assert wrong > 4 * rel


def test_camera_rays_equal_pixel_rays(exported):
    scene, out, side, _ = exported
    doc, _ = read_gltf(out.gltf)
    node = doc["nodes"][side["camera"]["node"]]
    camera = doc["cameras"][node["camera"]]
    w, h = side["image"]["width"], side["image"]["height"]
    expect = scene.camera.pixel_rays()
    rays = camera_rays(node, camera, w, h, side["image"]["pixel_center"])
    assert np.abs(rays - expect).max() < 1e-6
    assert np.allclose(node["translation"], scene.camera.origin, atol=0)
    assert np.abs(camera_rays(node, camera, w, h, fov_is_horizontal=True) - expect).max() > 1e-2
    p = camera["perspective"]
    assert 0 < p["znear"] < p["zfar"]
    corners = np.concatenate([o.mesh.positions for o in scene.objects]) - np.asarray(scene.camera.origin)
    depth = corners @ scene.camera.basis()[2]
    assert p["znear"] < depth.min() and depth.max() < p["zfar"]  # every vertex between the clip planes


def test_meshes_bit_for_bit_and_valid(exported):
    scene, out, side, _ = exported
    doc, meshes = read_gltf(out.gltf)
    assert doc["asset"]["version"] == "2.0"
    assert len(meshes) == len(scene.objects)
    for i, obj in enumerate(scene.objects):
        p, n, idx = meshes[side["objects"][i]["mesh"]]
        assert p.tobytes() == obj.mesh.positions.astype("<f4").tobytes()
        assert n.tobytes() == obj.mesh.normals.astype("<f4").tobytes()
        assert np.array_equal(idx, obj.mesh.indices)
        acc = doc["accessors"][doc["meshes"][i]["primitives"][0]["attributes"]["POSITION"]]
        assert acc["min"] == p.min(axis=0).tolist() and acc["max"] == p.max(axis=0).tolist()
    for v in doc["bufferViews"]:
        assert v["byteOffset"] % 4 == 0 and v["target"] in (34962, 34963) and "byteStride" not in v
    node_ids = doc["scenes"][doc["scene"]]["nodes"]
    assert sorted(node_ids) == list(range(len(scene.objects) + 1))


def test_materials(exported):
    scene, out, side, _ = exported
    doc, _ = read_gltf(out.gltf)
    for i, obj in enumerate(scene.objects):
        m, mat = obj.material, doc["materials"][i]
        pbr = mat["pbrMetallicRoughness"]
        if m.type == "pbr":
            assert pbr == {"baseColorFactor": [*m.base_color, 1.0], "metallicFactor": m.metallic,
                           "roughnessFactor": m.roughness}
        else:
            assert m.type == "diffuse"
            assert pbr["baseColorFactor"] == [*m.kd, 1.0] and pbr["metallicFactor"] == 0
            assert mat["extensions"]["KHR_materials_specular"]["specularFactor"] == 0
            assert "KHR_materials_specular" in doc["extensionsUsed"]
        assert mat["doubleSided"] == m.two_sided
        assert side["objects"][i]["exported_as"] == "exact"


def test_trimesh_reads_the_same_vertices_and_bounds(exported):
    trimesh = pytest.importorskip("trimesh")
    scene, out, _, _ = exported
    loaded = trimesh.load(out.gltf, process=False)
    count = sum(len(g.vertices) for g in loaded.geometry.values())
    assert count == sum(len(o.mesh.positions) for o in scene.objects)
    p = np.concatenate([o.mesh.positions for o in scene.objects])
    assert np.allclose(loaded.bounds, [p.min(axis=0), p.max(axis=0)], atol=1e-6)


def test_phong_refused_and_nearest(tmp_path):
    scene = scenes.load("builtin:sphere-phong")
    with pytest.raises(InputError, match=r"objects\[0\]\.material\.type = 'phong'"):
        export_scene(scene, tmp_path / "a")
    assert not (tmp_path / "a").exists()
    out = export_scene(scene, tmp_path / "b", nearest=True)
    side = json.loads(out.sidecar.read_text())
    assert side["objects"][0]["exported_as"] == "nearest" and side["objects"][0]["difference"]
    assert out.warnings and "nearest" in out.warnings[0]
    doc, _ = read_gltf(out.gltf)
    n = scene.objects[0].material.exponent
    # the Phong lobe about r with exponent N ~ a half-vector lobe of exponent 4N; Walter 2007: alpha^2 = 2/(Nh + 2)
    alpha = np.sqrt(2.0 / (4 * n + 2))
    assert doc["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] == pytest.approx(np.sqrt(alpha))


def test_existing_folder_refused_and_earlier_export_replaced(tmp_path):
    scene = scenes.load("builtin:sphere-diffuse")
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    with pytest.raises(InputError, match="not empty"):
        export_scene(scene, tmp_path / "mine")
    assert os.listdir(tmp_path / "mine") == ["notes.txt"]
    export_scene(scene, tmp_path / "out", fidelity_scenario=True)
    export_scene(scene, tmp_path / "out")  # an earlier export: replaced whole, its scenario file with it
    assert sorted(os.listdir(tmp_path / "out")) == sorted([GLTF, BIN, ENVIRONMENT, sidecar.NAME])
    assert sorted(os.listdir(tmp_path)) == ["mine", "out"]  # no temporary folder left


def test_an_earlier_export_holding_a_users_file_is_not_replaced(tmp_path):
    """An engine's image saved into an earlier export would be lost with the folder: refused, named."""
    scene = scenes.load("builtin:sphere-diffuse")
    export_scene(scene, tmp_path / "out")
    (tmp_path / "out" / "my_engine.exr").write_bytes(b"mine")
    before = sorted(os.listdir(tmp_path / "out"))
    with pytest.raises(InputError, match=r"out: holds 'my_engine.exr', which no iblcheck export writes"):
        export_scene(scene, tmp_path / "out")
    assert sorted(os.listdir(tmp_path / "out")) == before
    assert (tmp_path / "out" / "my_engine.exr").read_bytes() == b"mine"
    assert sorted(os.listdir(tmp_path)) == ["out"]


def test_a_folder_that_cannot_be_made_is_named_not_its_temporary(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError) as info:
        export_scene(scenes.load("builtin:sphere-diffuse"), tmp_path / "file" / "out")
    message = str(info.value)
    assert message.startswith(f"{tmp_path / 'file' / 'out'}: cannot write a folder in {tmp_path / 'file'}")
    assert ".tmp" not in message


def test_nothing_half_written(tmp_path, monkeypatch):
    scene = scenes.load("builtin:sphere-diffuse")

    def broken(path, rgb):
        path.write_bytes(b"#?RADIANCE\n")
        raise OSError(28, "No space left on device", str(path))

    export_scene(scene, tmp_path / "old")
    before = {p: (tmp_path / "old" / p).read_bytes() for p in os.listdir(tmp_path / "old")}
    monkeypatch.setattr(export_module.imageio, "write_hdr", broken)
    for target in ("new", "old"):
        with pytest.raises(OSError):
            export_scene(scene.with_overrides({"camera.fov_deg": 20.0}), tmp_path / target)
    assert sorted(os.listdir(tmp_path)) == ["old"]  # no new folder, no temporary one
    assert {p: (tmp_path / "old" / p).read_bytes() for p in os.listdir(tmp_path / "old")} == before
