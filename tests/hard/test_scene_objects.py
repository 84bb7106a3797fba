"""A scene names what it renders: without `[[objects]]` (or with an empty or malformed list) it is refused
with exit 2 and one line naming the file and the key, never a hidden default sphere."""

from __future__ import annotations

import tomllib
from importlib import resources

import pytest

import scenes
from experiments.cli import main as cli
from scenes import SceneError
from tests.hard.common import one_error_line, run_cli, write_tiny

CAMERA = '[camera]\norigin = [0.0, 0.0, 4.0]\nwidth = 8\nheight = 8\n'


def write(tmp_path, body: str = "", after: str = ""):
    """A scene file: its name, `body` (top-level keys or tables), the camera, then `after`."""
    path = tmp_path / "bare.toml"
    path.write_text('name = "bare"\n' + body + CAMERA + after)
    return path


@pytest.mark.parametrize("body, words", [
    ("", "objects: missing: a scene needs at least one [[objects]] table"),  # the case
    ("[realtime]\ntiming_frames = 1\n", "objects: missing"),  # other tables, still no object
    ("objects = []\n", "objects = []: must be a non-empty array of tables"),
    ("objects = {}\n", "objects = {}: must be a non-empty array of tables"),
    ("[objects]\nshape = \"sphere\"\n", "must be a non-empty array of tables"),  # a table, not an array of tables
    ("objects = \"sphere\"\n", "objects = 'sphere': must be a non-empty array of tables"),
    ("objects = [1]\n", "objects[0] must be a table"),
    ("objects = [[]]\n", "objects[0] must be a table"),
])
def test_a_scene_without_objects_is_refused_naming_file_and_key(tmp_path, body, words):
    path = write(tmp_path, body)
    with pytest.raises(SceneError) as err:
        scenes.load(path)
    message = str(err.value)
    assert message.startswith(f"{path}: ") and words in message and "\n" not in message


def test_the_cli_refuses_it_with_exit_2_and_one_line(tmp_path):
    out = run_cli("render", str(write(tmp_path)), "-o", str(tmp_path / "out.exr"))
    line = one_error_line(out)
    assert "bare.toml: objects: missing" in line
    assert not (tmp_path / "out.exr").exists()


def test_an_override_cannot_empty_the_list(tmp_path, capsys):
    code = cli.main(["render", str(write_tiny(tmp_path)), "--set", "objects=[]", "-o", str(tmp_path / "o.exr")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("error:") and "objects" in err[0]


def test_one_object_with_every_default_is_a_unit_sphere(tmp_path):
    """Negative control: `[[objects]]` with no keys is an explicit object; its defaults apply."""
    scene = scenes.load(write(tmp_path, after="[[objects]]\n"))
    assert len(scene.objects) == 1 and scene.objects[0].shape == "sphere"
    assert scene.objects[0].material.type == "diffuse"


def test_two_objects_are_both_kept(tmp_path):
    scene = scenes.load(write(tmp_path, after='[[objects]]\n[[objects]]\nshape = "plane"\n'))
    assert [o.shape for o in scene.objects] == ["sphere", "plane"]


def test_every_builtin_scene_names_its_objects():
    """The builtin scenes never relied on the default: each file has a non-empty [[objects]] array."""
    folder = resources.files("scenes").joinpath("data/scenes")
    files = sorted(f for f in folder.iterdir() if f.name.endswith(".toml"))
    assert len(files) >= 12
    for f in files:
        tree = tomllib.loads(f.read_text())
        assert isinstance(tree.get("objects"), list) and tree["objects"], f.name
        assert len(scenes.load(f"builtin:{f.name[:-5]}").objects) == len(tree["objects"])
