"""`realtime.renderer = "command"`: any engine as a command line (engines/command.py).

The engines here are small Python programs written by the tests; one of them is iblcheck itself
(`iblcheck render`), so the command route must reproduce `iblcheck compare`'s numbers exactly: a second
path to the same image. The others fail in each way an engine can, and each must end in its exit code with
the engine's words in the one error line.
"""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import numpy as np
import pytest

import realtime
import scenes
from engines import command, engine_timings
from experiments.cli.main import main
from experiments.measure import comparison

SIZE = 40

#: a fake engine: reads the sidecar, writes an image of the sidecar's size (or a planted fault) and timings
ENGINE = textwrap.dedent("""
    import json, sys, time
    args = dict(zip(sys.argv[1::2], sys.argv[2::2]))
    fault = args.get("--fault", "")
    if fault == "sleep":  # before the slow imports: on a loaded machine they alone can outlast the timeout
        sys.stderr.write("fake: still compiling shaders\\n"); sys.stderr.flush()
        time.sleep(30)
    import numpy as np
    from scenes.storage import imageio
    side = json.load(open(args["--sidecar"]))
    w, h = side["image"]["width"], side["image"]["height"]
    if fault == "missing":
        sys.stderr.write("fake: my GPU library is not installed\\n"); sys.exit(3)
    if fault == "reject":
        sys.stderr.write("x" * 2000 + "fake: cannot render this material\\n"); sys.exit(2)
    rgb = np.full((h, w, 3), 0.25, np.float32)
    if fault == "size":
        rgb = rgb[:-1]
    if fault == "nan":
        rgb[3, 4, 1] = np.nan
    if fault != "noimage":
        imageio.write_exr(args["--output"], rgb)
    if "--timings" in args:
        frames = [1.0, 2.0, 3.0, 100.0] if fault != "badtimings" else [1.0, -2.0]
        json.dump({"engine": "fake", "version": "9.9", "frame_ms": frames, "precompute_ms": 7.5},
                  open(args["--timings"], "w"))
    """)


def engine_scene(tmp_path: Path, args: str, base: str = "builtin:sphere-diffuse",
                 timeout_s: float = 60) -> scenes.Scene:
    script = tmp_path / "fake engine.py"  # a space in the path: each placeholder stays one argument
    script.write_text(ENGINE)
    template = f'{{python}} "{script}" --sidecar {{sidecar}} --output {{output}} {args}'
    return scenes.load(base).with_overrides({"camera.width": SIZE, "camera.height": SIZE,
                                             "realtime.renderer": "command", "realtime.command.template": template,
                                             "realtime.command.timeout_s": timeout_s})


def test_the_engine_image_and_its_timings_become_a_render(tmp_path):
    r = command.render(engine_scene(tmp_path, "--timings {timings}"))
    assert r.rgb.shape == (SIZE, SIZE, 3) and np.all(r.rgb == np.float32(0.25))
    assert r.mask.all()  # no alpha: the comparison takes the reference's coverage
    assert r.timings["draw"] == pytest.approx(2.5) and r.timings["precompute"] == 7.5  # the median of 1, 2, 3, 100
    assert r.meta["engine"] == "fake" and r.meta["engine_version"] == "9.9"


@pytest.mark.parametrize("fault, exit_code, words", [
    ("missing", 3, "my GPU library is not installed"),
    ("reject", 2, "cannot render this material"),
    ("size", 2, f"is {SIZE}x{SIZE - 1}, the scene's camera is {SIZE}x{SIZE}"),
    ("nan", 2, "1 pixel(s) hold NaN or Inf"),
    ("noimage", 2, "wrote no image"),
    ("badtimings", 2, "frame_ms[1] = -2.0"),
])
def test_each_way_an_engine_fails_has_its_exit_code_and_its_words(tmp_path, capsys, fault, exit_code, words):
    scene = engine_scene(tmp_path, f"--timings {{timings}} --fault {fault}")
    path = tmp_path / "scene.toml"
    path.write_text(_toml(scene))
    assert main(["render", str(path), "-o", str(tmp_path / "out.exr")]) == exit_code
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err
    assert len(err[0]) < 1200  # the engine's stderr is cut short (the reject case writes 2000 x's)
    assert not (tmp_path / "out.exr").exists()


def test_a_missing_program_is_a_missing_capability(tmp_path):
    scene = engine_scene(tmp_path, "").with_overrides(
        {"realtime.command.template": "/nonexistent/engine --out {output}"})
    with pytest.raises(scenes.MissingCapability, match="'/nonexistent/engine' was not found"):
        command.render(scene)


def test_an_engine_past_its_timeout_is_stopped_and_named(tmp_path):
    with pytest.raises(command.EngineRejected, match=r"realtime.command.timeout_s = 2 s") as info:
        command.render(engine_scene(tmp_path, "--fault sleep", timeout_s=2))
    assert "still compiling shaders" in str(info.value)  # what the engine said before it was stopped


@pytest.mark.parametrize("template, words", [
    ("{python} {scene_file}", "unknown placeholder {scene_file}"),
    ("{python} '{output}", "no command line"),
    ("   ", "realtime.command"),  # refused at load: an empty template names no engine
])
def test_bad_templates_are_refused_naming_the_key(tmp_path, template, words):
    with pytest.raises(scenes.InputError, match=words.replace("{", r"\{").replace("}", r"\}")):
        command.render(engine_scene(tmp_path, "").with_overrides({"realtime.command.template": template}))


def test_timings_file_values_are_checked_against_their_meaning(tmp_path):
    path = tmp_path / "t.json"
    path.write_text(json.dumps({"frame_ms": [2.0, 4.0, 6.0], "engine": "x"}))
    t = engine_timings.read(path)
    assert t.as_render_timings()["draw"] == 4.0 and "precompute" not in t.as_render_timings()
    for bad, key in (({"frame_ms": "fast"}, "frame_ms"), ({"frame_ms": []}, "frame_ms"),
                     ({"precompute_ms": -1.0}, "precompute_ms"), ({"precompute_ms": float("nan")}, "NaN"),
                     ({"engine": 3}, "engine")):
        path.write_text(json.dumps(bad))
        with pytest.raises(scenes.InputError, match=key):
            engine_timings.read(path)


@pytest.mark.parametrize("key, value, meant", [("frame_msec", [2.5, 3.5], "frame_ms"),
                                              ("precompute", 41.0, "precompute_ms"), ("engnie", "x", "engine")])
def test_a_misspelt_timings_key_is_refused_naming_the_key_meant(tmp_path, key, value, meant):
    path = tmp_path / "t.json"
    path.write_text(json.dumps({key: value}))
    with pytest.raises(scenes.InputError, match=rf"t.json: {key} is not a timings key; did you mean {meant}\?"):
        engine_timings.read(path)


def test_an_engines_own_keys_are_left_unread(tmp_path):
    """What the bundled engines add beside the read keys (load and first-frame times, a median they computed)
    is theirs: not refused, even where close to a read key that the file also holds."""
    path = tmp_path / "t.json"
    path.write_text(json.dumps({"frame_ms": [2.0], "median_frame_ms": 2.0, "first_frame_ms": 90.0, "load_ms": 5.0,
                                "render_s": 1.0, "spp": 64, "seed": 0}))
    assert engine_timings.read(path).as_render_timings()["draw"] == 2.0
    # keys close to a read key the file lacks, but another kind of value or that key with a word added
    path.write_text(json.dumps({"engine": "x", "gl_version": "4.6", "frames": 120, "frame_ms": [2.0]}))
    assert engine_timings.read(path).as_render_timings()["draw"] == 2.0
    path.write_text(json.dumps({"engine": "x", "version": "1", "frames": 120}))
    assert engine_timings.read(path).as_render_timings() == {}


def test_the_opengl_renderer_refuses_a_command_scene(tmp_path):
    with pytest.raises(scenes.InputError, match="external engine"):
        realtime.render(engine_scene(tmp_path, ""))


@pytest.mark.gl
@pytest.mark.mitsuba
@pytest.mark.slow
def test_iblcheck_itself_as_a_command_engine_scores_exactly_as_iblcheck_compare(tmp_path):
    """The engine is `iblcheck render` of the same scene (an EXR with alpha = coverage): its comparison through
    the command route must give the metrics the direct route gives, to the last bit."""
    overrides = {"camera.width": SIZE, "camera.height": SIZE, "reference.spp": 64}
    direct = scenes.load("builtin:sphere-diffuse").with_overrides(overrides)
    sets = " ".join(f"--set {k}={v}" for k, v in overrides.items())
    template = f"{{python}} -m experiments.cli render builtin:sphere-diffuse {sets} -o {{output}}"
    via_command = direct.with_overrides({"realtime.renderer": "command", "realtime.command.template": template})
    a = comparison.run(direct).metrics
    b = comparison.run(via_command).metrics
    for key in ("psnr", "ssim", "flip", "rel_mse", "pixels"):
        assert a[key] == b[key], key
    # negative control: the same engine rendering another exposure is scored differently
    darker = via_command.with_overrides({"realtime.command.template": template.replace(
        "-o {output}", "--set environment.scale=0.8 -o {output}")})
    assert comparison.run(darker).metrics["psnr"] < a["psnr"] - 1.0


def _toml(scene: scenes.Scene) -> str:
    """The scene as a TOML file (the keys these tests set on a builtin)."""
    c, rt = scene.camera, scene.realtime.command
    return textwrap.dedent(f"""
        name = "engine-test"
        [camera]
        width = {c.width}
        height = {c.height}
        [[objects]]
        shape = "sphere"
        material = {{ type = "diffuse", kd = [0.8, 0.8, 0.8] }}
        [realtime]
        renderer = "command"
        [realtime.command]
        template = {json.dumps(rt.template)}
        timeout_s = {rt.timeout_s}
        """)

