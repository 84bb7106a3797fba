"""Bad scene files through the CLI: exit 2, one `error:` line naming the file and the key, no traceback."""

from __future__ import annotations

import pytest

from tests.hard.common import one_error_line, run_cli, write_tiny

CASES = [  # (what is wrong, TOML appended or replaced, words the error must contain)
    ("malformed TOML", "[camera\nfov_deg = 1", ["malformed TOML"]),
    ("wrong type", '[tonemap]\nkey = "bright"', ["tonemap.key", "'bright'"]),
    ("unknown key", "[tonemap]\ngamma = 2.2", ["tonemap.gamma", "unknown key"]),
    ("unknown top-level key", "[lights]\nsun = 1", ["lights", "unknown key"]),
    ("gate out of range", "[gate]\nmin_psnr = 1e9", ["gate.min_psnr"]),
    ("negative scale", None, ["environment.scale"]),
    ("exponent < 0", None, ["material.exponent"]),
    ("f0 > 1", None, ["material.f0"]),
    ("kd > 1", None, ["material.kd"]),
    ("base not a power of two", "[realtime]\nbase_size = 100", ["realtime.base_size", "power of two"]),
    ("face size not a power of two", "[realtime]\nface_size = 48", ["realtime.face_size", "power of two"]),
    ("spp 0", None, ["reference.spp"]),
    ("integrator", '[reference]\nintegrator = "bdpt"', ["reference.integrator"]),
    ("sh window", '[realtime]\nsh_window = "gauss"', ["realtime.sh_window"]),
]
REPLACE = {
    "negative scale": ('map = "builtin:uffizi"', 'map = "builtin:uffizi"\nscale = -1.0'),
    "exponent < 0": ('{ type = "blend" }', '{ type = "blend", exponent = -1.0 }'),
    "f0 > 1": ('{ type = "blend" }', '{ type = "blend", f0 = 1.5 }'),
    "kd > 1": ('{ type = "blend" }', '{ type = "blend", kd = [2.0, 0.5, 0.5] }'),
    "spp 0": ("spp = 8", "spp = 0"),
}


@pytest.mark.parametrize(("what", "extra", "words"), CASES, ids=[c[0] for c in CASES])
def test_bad_scene_file_exits_2_naming_file_and_key(tmp_path, what, extra, words):
    path = write_tiny(tmp_path, name="bad")
    text = path.read_text()
    if what in REPLACE:
        old, new = REPLACE[what]
        text = text.replace(old, new)
    elif what.startswith("malformed"):
        text += extra
    else:
        # into a table the file already has (TOML forbids a table twice), or as a new table
        header, body = extra.split("\n", 1)
        text = text.replace(header + "\n", header + "\n" + body + "\n", 1) if header in text else text + "\n" + extra
    path.write_text(text)
    line = one_error_line(run_cli("render", str(path), "-o", str(tmp_path / "out.exr")))
    assert "bad.toml" in line
    for w in words:
        assert w in line, line


@pytest.mark.parametrize(("camera", "words"), [
    ("fov_deg = 0.0", ["camera.fov_deg"]), ("fov_deg = 180.0", ["camera.fov_deg"]),
    ("up = [0.0, 0.0, 1.0]", ["camera.up", "parallel"]), ("target = [0.0, 0.0, 4.0]", ["camera.target"]),
    ("width = 0", ["camera.width"]), ("height = 2.5", ["camera.height"])])
def test_bad_camera_exits_2(tmp_path, camera, words):
    path = write_tiny(tmp_path, name="cam")
    key = camera.split(" = ")[0]
    lines = [line for line in path.read_text().splitlines() if not line.startswith(key + " = ")]
    path.write_text("\n".join(lines).replace("[camera]", "[camera]\n" + camera, 1))
    line = one_error_line(run_cli("render", str(path)))
    assert "cam.toml" in line and all(w in line for w in words), line


def test_missing_scene_and_missing_env_file(tmp_path):
    line = one_error_line(run_cli("render", str(tmp_path / "nope.toml")))
    assert "nope.toml" in line and "not found" in line
    path = write_tiny(tmp_path, env="missing.exr", name="noenv")
    line = one_error_line(run_cli("render", str(path)))
    assert "noenv.toml" in line and "environment.map" in line and "not found" in line
