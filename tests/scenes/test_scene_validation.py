"""Every validation rule of the scene format (docs/contract.md section 5) names the file and the key."""

from __future__ import annotations

import pickle

import pytest

import scenes
from scenes import SceneError
from scenes.model import scene as scene_model
from tests.helpers import write_scene

BASE = """
[camera]
origin = [0.0, 0.0, 4.0]
[[objects]]
shape = "sphere"
material = { type = "blend", kd = [0.8, 0.8, 0.8], ks = [1.0, 1.0, 1.0], exponent = 100.0, f0 = 0.04 }
"""

BAD = [
    # (extra or replaced TOML, key the message must name, words it must contain)
    ("[environment]\nscale = -1.0", "environment.scale", "[0, 1e+09]"),
    ("[environment]\nmap = \"builtin:nowhere\"", "nowhere", "uffizi"),
    ("[environment]\nmap = \"missing.exr\"", "environment.map", "not found"),
    ("[environment]\nmap = \"builtin:sky\"\nparams = { sun = 1e7 }", "environment.params.sun", "1e+06"),
    ("[environment]\nmap = \"builtin:sky\"\nparams = { moon = 1 }", "environment.params.moon", "sun"),
    ("[environment]\ncolour = 1", "environment.colour", "unknown key"),
    ("[tonemap]\nkey = 0.0", "tonemap.key", "(0, 100]"),
    ("[tonemap]\nwhite = \"bright\"", "tonemap.white", "a number"),
    ("[realtime]\nbase_size = 100", "realtime.base_size", "power of two"),
    ("[realtime]\nface_size = 48", "realtime.face_size", "power of two"),
    ("[realtime]\nbase_size = 64\nface_size = 128", "realtime.face_size", "base_size"),
    ("[realtime]\nlod_mapping = \"linear\"", "realtime.lod_mapping", '"paper"'),
    ("[realtime]\nsh_window = \"gauss\"", "realtime.sh_window", '"lanczos"'),
    ("[reference]\nspp = 0", "reference.spp", "an integer in [1, 16777216]"),  # 2^24 written whole, not 1.67772e+07
    ("[reference]\nspp = 1.5", "reference.spp", "integer"),
    ("[reference]\nintegrator = \"bdpt\"", "reference.integrator", '"path"'),
    ("[reference]\nmodel = \"ggx\"", "reference.model", '"physical"'),
    ("[gate]\nmin_ssim = 2.0", "gate.min_ssim", "[-1, 1]"),
    ("[gate]\nmax_psnr = 2.0", "gate.max_psnr", "unknown key"),
    ("extra = 1", "extra", "unknown key"),
]


@pytest.mark.parametrize("snippet,key,words", BAD, ids=[b[1] for b in BAD])
def test_bad_value_names_file_and_key(tmp_path, snippet, key, words):
    path = write_scene(tmp_path, snippet + "\n" + BASE)
    with pytest.raises(SceneError) as err:
        scenes.load(path)
    msg = str(err.value)
    assert str(path) in msg and key in msg and words in msg, msg


BAD_CAMERA = [
    ("fov_deg = 0.0", "camera.fov_deg"),
    ("fov_deg = 180.0", "camera.fov_deg"),
    ("width = 0", "camera.width"),
    ("height = 2.5", "camera.height"),
    ("origin = [0.0, 1.0]", "camera.origin"),
    ("up = [0.0, 0.0, 1.0]", "camera.up"),  # parallel to the view direction (origin on +Z)
    ("target = [0.0, 0.0, 4.0]", "camera.target"),  # equal to the origin
]


@pytest.mark.parametrize("line,key", BAD_CAMERA, ids=[b[0] for b in BAD_CAMERA])
def test_bad_camera(tmp_path, line, key):
    text = f"[camera]\norigin = [0.0, 0.0, 4.0]\n{line}\n" if "origin" not in line else f"[camera]\n{line}\n"
    path = write_scene(tmp_path, text)
    with pytest.raises(SceneError, match=key.replace(".", r"\.")):
        scenes.load(path)


BAD_MATERIAL = [
    ('{ type = "blend", exponent = -1.0 }', "material.exponent"),
    ('{ type = "blend", f0 = 1.5 }', "material.f0"),
    ('{ type = "diffuse", kd = [0.5, 0.5, 2.0] }', "material.kd"),
    ('{ type = "phong", ks = [-0.1, 0.5, 0.5] }', "material.ks"),
    ('{ type = "diffuse", exponent = 10.0 }', "material.exponent"),  # does not apply to diffuse
    ('{ type = "metal" }', "material.type"),
]


@pytest.mark.parametrize("material,key", BAD_MATERIAL, ids=[b[1] + str(i) for i, b in enumerate(BAD_MATERIAL)])
def test_bad_material(tmp_path, material, key):
    path = write_scene(tmp_path, f"[[objects]]\nshape = \"sphere\"\nmaterial = {material}\n")
    with pytest.raises(SceneError, match=r"objects\[0\]\." + key.replace(".", r"\.")):
        scenes.load(path)


@pytest.mark.parametrize("line,key", [
    ('shape = "cube"', "objects[0].shape"),
    ('shape = "mesh.obj"', "objects[0].shape"),
    ("scale = 0.0", "objects[0].scale"),
    ("translate = [0.0, 0.0]", "objects[0].translate"),
    ("resolution = 1", "objects[0].resolution"),
])
def test_bad_object(tmp_path, line, key):
    path = write_scene(tmp_path, f"[[objects]]\n{line}\n")
    with pytest.raises(SceneError) as err:
        scenes.load(path)
    assert key in str(err.value) and str(path) in str(err.value)


def test_malformed_toml_names_file(tmp_path):
    path = write_scene(tmp_path, "[camera\norigin = ")
    with pytest.raises(SceneError, match="malformed TOML"):
        scenes.load(path)


def test_missing_file():
    with pytest.raises(SceneError, match="not found"):
        scenes.load("/nonexistent/scene.toml")


def test_defaults_and_name_from_stem(tmp_path):
    scene = scenes.load(write_scene(tmp_path, "[[objects]]\n", name="plain.toml"))  # one object, all defaults
    assert scene.name == "plain"
    assert scene.environment.map == "builtin:uffizi"
    assert scene.camera.fov_deg == 30.0 and (scene.camera.width, scene.camera.height) == (256, 256)
    assert scene.realtime.face_size == 64 and scene.reference.spp == 1024
    assert scene.objects[0].material.type == "diffuse" and scene.objects[0].shape == "sphere"


def test_env_path_relative_to_scene_file(tmp_path):
    from scenes.environment import environments, envmap

    sub = tmp_path / "maps"
    sub.mkdir()
    envmap.write(sub / "c.exr", environments.builtin("constant"))
    scene_dir = tmp_path / "scenes"
    scene_dir.mkdir()
    path = write_scene(scene_dir, '[environment]\nmap = "../maps/c.exr"\n[[objects]]\n')
    scene = scenes.load(path)
    assert scene.environment.map == str(scene_dir / "../maps/c.exr")
    assert scene.environment.radiance().shape == (32, 64, 3)


def test_overrides_convert_types_and_revalidate():
    scene = scenes.load("builtin:sphere-blend")
    s2 = scene.with_overrides({"realtime.lod_bias": "2", "realtime.face_size": "auto",
                               "objects.*.material.exponent": "10", "tonemap.key": 0.5})
    assert s2.realtime.lod_bias == 2.0 and isinstance(s2.realtime.lod_bias, float)
    assert s2.realtime.face_size == "auto"
    assert s2.objects[0].material.exponent == 10.0
    assert s2.tonemap.key == 0.5
    assert scene.realtime.lod_bias == 0.0  # the original is unchanged
    with pytest.raises(SceneError, match=r"realtime\.face_size"):
        scene.with_overrides({"realtime.face_size": "48"})
    with pytest.raises(SceneError, match=r"realtime\.bias"):
        scene.with_overrides({"realtime.bias": "1"})


def test_override_path_is_relative_to_cwd(tmp_path, monkeypatch):
    from scenes.environment import environments, envmap

    envmap.write(tmp_path / "c.exr", environments.builtin("constant"))
    monkeypatch.chdir(tmp_path)
    scene = scenes.load("builtin:sphere-diffuse").with_overrides({"environment.map": "c.exr"})
    assert scene.environment.map == str(tmp_path / "c.exr")


@pytest.mark.parametrize("name,expected", [
    ("sphere-blend", {"diffuse", "glossy", "fresnel"}),
    ("sphere-diffuse", {"diffuse"}),
    ("sphere-phong", {"glossy"}),
    ("torus-phong", {"glossy", "occlusion", "interreflection"}),
    ("bowl-diffuse", {"diffuse", "occlusion", "interreflection"}),
    ("teapot-blend", {"diffuse", "glossy", "fresnel", "occlusion", "interreflection"}),
])
def test_effects_follow_the_scene(name, expected):
    assert scenes.load(f"builtin:{name}").effects == frozenset(expected)


def test_effects_two_convex_objects_occlude(tmp_path):
    text = "[[objects]]\nshape = \"sphere\"\n[[objects]]\nshape = \"sphere\"\ntranslate = [2.5, 0.0, 0.0]\n"
    assert {"occlusion", "interreflection"} <= scenes.load(write_scene(tmp_path, text)).effects


def test_effects_black_diffuse_is_no_diffuse(tmp_path):
    text = '[[objects]]\nmaterial = { type = "blend", kd = [0.0, 0.0, 0.0], ks = [1.0, 1.0, 1.0] }\n'
    assert scenes.load(write_scene(tmp_path, text)).effects == frozenset({"glossy", "fresnel"})


def test_every_builtin_scene_loads():
    names = scenes.builtin_names()
    required = {"sphere-diffuse", "sphere-phong", "sphere-blend", "teapot-blend", "torus-phong", "bowl-diffuse"}
    assert required <= set(names)
    envs = {scenes.load(f"builtin:{n}").environment.map for n in names}
    assert len(envs) >= 4  # under different builtin environments


@pytest.mark.parametrize("shape", ["pawn", "rook"])
def test_a_packaged_model_has_no_resolution_to_choose(shape):
    # an error about two keys is named as the file would name them, whichever of them an override set
    with pytest.raises(SceneError, match=rf"objects\[0\].resolution = 8 with objects\[0\].shape = '{shape}'"):
        scenes.load("builtin:sphere-diffuse").with_overrides({"objects.0.shape": shape, "objects.0.resolution": 8})


def test_a_new_environment_map_drops_the_old_maps_params():
    """builtin:sphere-sky's params (the sun) are builtin:sky's: swept onto another map they would be refused
    as unknown, so a new map starts without them; the same map keeps them, and params given with it are used."""
    sky = scenes.load("builtin:sphere-sky")
    assert sky.environment.params  # the precondition: the scene sets sky parameters
    other = sky.with_overrides({"environment.map": "builtin:ennis"})
    assert other.environment.map == "builtin:ennis" and other.environment.params == ()
    assert sky.with_overrides({"environment.map": "builtin:sky"}).environment.params == sky.environment.params
    with pytest.raises(SceneError, match="environment.params.sun: unknown parameter for builtin:ennis"):
        sky.with_overrides({"environment.map": "builtin:ennis", "environment.params.sun": 2.0})


def test_an_unknown_key_only_an_override_names_is_blamed_on_the_override(tmp_path):
    """`--set camera.fovv=3` on a good file: the file holds no such key, so the error names the override."""
    scene = scenes.load("builtin:sphere-diffuse")
    with pytest.raises(SceneError, match=r"^builtin:sphere-diffuse: override camera.fovv: unknown key; allowed: "):
        scene.with_overrides({"camera.fovv": 3})


def test_a_bad_value_an_override_gives_is_blamed_on_the_override(tmp_path):
    """`--set camera.width=-8` on a good file: the error names the override as typed, not a key of the file.
    Control: the same value written in the file is named as the file's key."""
    scene = scenes.load("builtin:sphere-diffuse")
    with pytest.raises(SceneError, match=r"^builtin:sphere-diffuse: override camera.fov_deg = -3: must be "):
        scene.with_overrides({"camera.fov_deg": -3})
    with pytest.raises(SceneError, match=r"^builtin:sphere-diffuse: override objects.\*.scale = -2: must be "):
        scene.with_overrides({"objects.*.scale": -2})
    path = write_scene(tmp_path, '[environment]\nmap = "builtin:uffizi"\n[camera]\nfov_deg = -3\n[[objects]]\n'
                                 'shape = "sphere"\nmaterial = { type = "diffuse", kd = [0.5, 0.5, 0.5] }\n')
    with pytest.raises(SceneError, match=r": camera.fov_deg = -3: must be ") as err:
        scenes.load(str(path))
    assert ": override " not in str(err.value)


@pytest.mark.parametrize("override, words", [
    ({"objects.0.shapee": "sphere"}, "override objects.0.shapee: objects[0].shapee: unknown key"),
    ({"objects.*.scalee": 2}, "override objects.*.scalee: objects[0].scalee: unknown key"),
    ({"camer.fov_deg": 3}, "override camer.fov_deg: camer: unknown key"),
])
def test_an_unknown_object_or_section_key_of_an_override_is_the_overrides(override, words):
    with pytest.raises(SceneError) as err:
        scenes.load("builtin:sphere-diffuse").with_overrides(override)
    assert str(err.value).startswith(f"builtin:sphere-diffuse: {words}")



def test_a_bad_value_keeps_its_key_through_pickling():
    """A Dask worker's scene error reaches the driver pickled: the key the overrides are matched against survives,
    and so does the message. Control: a plain SceneError carries no key."""
    with pytest.raises(scene_model.BadValue) as err:
        scenes.load("builtin:sphere-diffuse").with_overrides({"reference.spp": 0})
    back = pickle.loads(pickle.dumps(err.value))
    assert isinstance(back, scene_model.BadValue) and str(back) == str(err.value)
    assert back.key == "override reference.spp" and back.detail.startswith("0: must be an integer in [1, ")
    assert not hasattr(SceneError("x"), "key")
