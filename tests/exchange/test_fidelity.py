"""glTF Render Fidelity scenarios: written by `export --fidelity-scenario`, read back as iblcheck scenes."""

from __future__ import annotations

import json

import numpy as np
import pytest

import scenes
from experiments.cli.inputs import load_scene
from experiments.cli.main import main
from scenes.environment import envmap
from scenes.exchange.export import export_scene
from scenes.exchange.fidelity import read_scenario
from scenes.storage.errors import InputError
from tests.exchange.gltf_numpy import centre_direction

RGBE = 2.0 ** -8
#: pawn-pbr's map turns 60 degrees (baked into the scenario's lighting); the camera moved off the +Z axis
#: so the orbit's theta is not 0
CASES = {"spheres-pbr-grid": {}, "pawn-pbr": {"camera.origin": [2.0, 1.2, 3.0]},
         "sphere-diffuse": {"camera.origin": [-3.0, -1.0, 2.0], "camera.target": [0.1, 0.2, 0.0]}}


@pytest.fixture(scope="module", params=list(CASES))
def round_trip(request, tmp_path_factory):
    scene = scenes.load(f"builtin:{request.param}").with_overrides(
        {"camera.width": 48, "camera.height": 32, **CASES[request.param]})
    out = export_scene(scene, tmp_path_factory.mktemp("fid") / "out", fidelity_scenario=True)
    return scene, out, read_scenario(out.scenario)


def test_scenario_format(round_trip):
    scene, out, _ = round_trip
    s = json.loads(out.scenario.read_text())
    assert set(s) == {"name", "model", "lighting", "dimensions", "target", "orbit", "verticalFoV", "renderSkybox"}
    assert (out.folder / s["model"]).is_file() and (out.folder / s["lighting"]).is_file()
    # model-viewer's orbit (degrees): eye = target + r (sin phi sin theta, cos phi, sin phi cos theta)
    t, p, r = np.radians(s["orbit"]["theta"]), np.radians(s["orbit"]["phi"]), s["orbit"]["radius"]
    eye = np.array([s["target"][k] for k in "xyz"]) + r * np.array(
        [np.sin(p) * np.sin(t), np.cos(p), np.sin(p) * np.cos(t)])
    assert np.allclose(eye, scene.camera.origin, atol=1e-9)
    assert s["verticalFoV"] == scene.camera.fov_deg


def test_camera_round_trips(round_trip):
    scene, _, back = round_trip
    assert np.abs(back.camera.pixel_rays() - scene.camera.pixel_rays()).max() < 1e-6
    assert (back.camera.width, back.camera.height) == (scene.camera.width, scene.camera.height)


def test_camera_negative_control_theta_convention(round_trip, tmp_path):
    """theta measured from +X (a wrong reading of model-viewer's orbit) moves the camera."""
    scene, out, _ = round_trip
    s = json.loads(out.scenario.read_text())
    s["orbit"]["theta"] = 90.0 - s["orbit"]["theta"]  # sin and cos of theta swapped
    (out.folder / "wrong.json").write_text(json.dumps(s))
    wrong = read_scenario(out.folder / "wrong.json")
    assert np.abs(wrong.camera.pixel_rays() - scene.camera.pixel_rays()).max() > 1e-2


def test_environment_round_trips(round_trip):
    """At every viewer texel centre the read scene's lookup is the original's (rotation included) within RGBE."""
    scene, out, back = round_trip
    env = scene.environment.radiance()
    h, w = env.shape[:2]
    rng = np.random.default_rng(3)
    r, c = rng.integers(0, h, 2000), rng.integers(0, w, 2000)
    d = centre_direction(r, c, h, w)
    expect = envmap.lookup(env, d, scene.environment.rotation_deg).astype(np.float64)
    got = envmap.lookup(back.environment.radiance(), d, back.environment.rotation_deg).astype(np.float64)
    tol = RGBE * expect.max(axis=-1) + 1e-6 * float(env.mean())
    assert (np.abs(got - expect).max(axis=-1) <= tol).all()
    unturned = envmap.lookup(env, d, 0.0).astype(np.float64)
    if scene.environment.rotation_deg:  # negative control: the rotation left out of the lighting
        assert np.median(np.abs(got - unturned).max(axis=-1) / tol) > 1.0
    # between centres: close in the mean
    dr = rng.normal(size=(20000, 3))
    e2 = envmap.lookup(env, dr, scene.environment.rotation_deg).astype(np.float64)
    g2 = envmap.lookup(back.environment.radiance(), dr, 0.0).astype(np.float64)
    assert np.abs(g2 - e2).mean() / e2.mean() < 0.05


def test_materials_and_meshes_round_trip(round_trip):
    scene, _, back = round_trip
    assert len(back.objects) == len(scene.objects)
    for a, b in zip(scene.objects, back.objects, strict=True):
        assert a.material == b.material
        assert np.array_equal(a.mesh.positions, b.mesh.positions)
        assert np.abs(a.mesh.normals - b.mesh.normals).max() < 1e-6
        assert np.array_equal(a.mesh.indices, b.mesh.indices)


def test_up_vector_refused(tmp_path):
    scene = scenes.load("builtin:sphere-diffuse").with_overrides({"camera.up": [0.3, 1.0, 0.0]})
    with pytest.raises(InputError, match=r"camera\.up"):
        export_scene(scene, tmp_path / "x", fidelity_scenario=True)
    assert not (tmp_path / "x").exists()


def test_textured_material_refused(tmp_path):
    scene = scenes.load("builtin:sphere-diffuse")
    out = export_scene(scene, tmp_path / "x", fidelity_scenario=True)
    doc = json.loads(out.gltf.read_text())
    doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    out.gltf.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"scene\.gltf.*material 0 \('object_0'\): textured \(baseColorTexture\)"):
        read_scenario(out.scenario)


def test_cli_export_and_load(tmp_path, capsys):
    assert main(["export", "builtin:sphere-diffuse", str(tmp_path / "e"), "--fidelity-scenario"]) == 0
    assert json.loads(capsys.readouterr().out)["files"][-1] == "scenario.json"
    scene = load_scene(str(tmp_path / "e" / "scenario.json"))
    assert scene.objects[0].material.type == "diffuse"
    assert main(["export", "builtin:sphere-phong", str(tmp_path / "p")]) == 2
    assert "objects[0].material.type = 'phong'" in capsys.readouterr().err
