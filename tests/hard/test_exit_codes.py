"""Exit codes keep their meaning.

1 is only ever "a gate failed"; bad input and unusable paths 2; a missing machine dependency (or memory) 3;
an internal error 4, one line, the traceback only under --debug; Ctrl-C 130, resumable. Every input that once
tracebacked (symbolic link loops, non-UTF-8 or deeply nested TOML, corrupt result lines, map values near the
float32 maximum, a vanishing field of view, ...) is a clear refusal or a correct finite render.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from experiments.cli import entry
from experiments.cli import main as cli
from experiments.measure.results import RESULTS
from experiments.paper import e06_hostile_cases as hostile
from experiments.paper.e06_hostile_runs import tiny_scene
from scenes import MissingCapability
from scenes.storage import imageio
from tests.hard.common import ROOT

INTERNAL = [ZeroDivisionError("division by zero"), AttributeError("'NoneType' object has no attribute 'x'"),
            KeyError("k"), IndexError("list index out of range"), TypeError("bad"), AssertionError("no"),
            RecursionError("deep"), RuntimeError("GL error"), FloatingPointError("NaN in the reference"),
            NotImplementedError(), OSError("no file name")]


def run(func, debug: bool = False, capsys=None) -> tuple[int, list[str], str]:
    code = cli.run_command(argparse.Namespace(func=func), debug)
    err = capsys.readouterr().err
    return code, err.strip().splitlines(), err


def raising(exc):
    def func(args):
        raise exc

    return func


@pytest.mark.parametrize("exc", INTERNAL, ids=[type(e).__name__ for e in INTERNAL])
def test_an_internal_error_exits_4_with_one_line(capsys, exc):
    code, lines, err = run(raising(exc), capsys=capsys)
    assert code == cli.EXIT_INTERNAL == 4
    assert len(lines) == 1 and lines[0].startswith("error: internal error") and "--debug" in lines[0]
    assert "Traceback" not in err


def test_debug_adds_the_traceback(capsys):
    code, lines, err = run(raising(ZeroDivisionError("x")), debug=True, capsys=capsys)
    assert code == 4 and "Traceback" in err and lines[-1].startswith("error: internal error")


def test_debug_is_taken_anywhere_on_the_command_line(capsys, monkeypatch):
    monkeypatch.setattr(cli, "_cmd_report", raising(ValueError("boom")))  # looked up when the parser is built
    for argv in (["--debug", "report", "x"], ["report", "x", "--debug"]):
        assert cli.main(argv) == 4
        assert "Traceback" in capsys.readouterr().err
    assert cli.main(["report", "x"]) == 4
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.parametrize(("exc", "code", "words"), [
    (KeyboardInterrupt(), 130, "interrupted"), (MemoryError(), 3, "out of memory"),
    (MissingCapability("no OpenGL 4.3 context", "install libegl1"), 3, "libegl1"),
    (OSError(28, "No space left on device", "/data/out.exr"), 2, "/data/out.exr: No space left"),
    (cli.UsageError("bad flag"), 2, "bad flag"),
])
def test_other_endings_keep_their_codes(capsys, exc, code, words):
    got, lines, err = run(raising(exc), capsys=capsys)
    assert got == code and len(lines) == 1 and words in lines[0] and "Traceback" not in err


def test_a_crash_inside_the_gate_is_not_a_failed_gate(tmp_path, capsys, monkeypatch):
    from experiments.measure import comparison

    # the gate measures in announced steps (gate.measure), each of which ends in comparison.compare
    monkeypatch.setattr(comparison, "compare", raising(RuntimeError("the GL driver crashed")))
    code = cli.main(["gate", str(tiny_scene(tmp_path)), "--min-psnr", "10"])
    assert code == 4 and "internal error" in capsys.readouterr().err


@pytest.mark.parametrize("flag", ["--min-psnr", "--min-ssim", "--max-flip"])
@pytest.mark.parametrize("value", ["nan", "NaN", "inf", "-inf", "1e999", "abc", "", "0x10", "1e3000"])
def test_thresholds_must_be_finite_numbers(tmp_path, capsys, monkeypatch, flag, value):
    from experiments.measure import comparison

    monkeypatch.setattr(comparison, "compare", raising(AssertionError("compared before the thresholds were checked")))
    code = cli.main(["gate", str(tiny_scene(tmp_path)), f"{flag}={value}"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and flag in err[0], err


@pytest.mark.parametrize(("flag", "value"), [("--min-ssim", "1.5"), ("--min-ssim", "-2"), ("--max-flip", "-0.1"),
                                             ("--max-flip", "1.01"), ("--min-psnr", "1e4")])
def test_thresholds_out_of_range(tmp_path, capsys, flag, value):
    assert cli.main(["gate", str(tiny_scene(tmp_path)), f"{flag}={value}"]) == 2
    assert "must be a number in" in capsys.readouterr().err


# --------------------------------------------------------------------------- inputs that once tracebacked


def refused(capsys, argv: list[str]) -> str:
    code = cli.main(argv)
    err = capsys.readouterr().err
    lines = [x for x in err.strip().splitlines() if not x.startswith("warning:")]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: "), (code, err)
    assert not hostile.python_text(lines[0]), lines[0]
    return lines[0]


def test_symbolic_link_loops_as_scene_map_and_mesh(tmp_path, capsys):
    (tmp_path / "s").mkdir()
    loops = {suffix: hostile.special_paths(tmp_path / "s", suffix)[0][1] for suffix in (".exr", ".obj", ".toml")}
    assert "symbolic link loop" in refused(capsys, ["render", str(loops[".toml"])])
    assert "symbolic link loop" in refused(capsys, ["render", str(tiny_scene(tmp_path, "m", env=str(loops[".exr"])))])
    assert "symbolic link loop" in refused(capsys, ["render", str(tiny_scene(tmp_path, "o", shape=str(loops[".obj"])))])
    line = refused(capsys, ["render", str(tiny_scene(tmp_path)), "--set", f"environment.map={loops['.exr']}"])
    assert "symbolic link loop" in line  # --set paths are not resolved (Path.resolve raised on a loop)
    line = refused(capsys, ["sweep", str(tiny_scene(tmp_path)), "--envs", str(loops[".exr"]), "--out",
                            str(tmp_path / "sw")])
    assert "symbolic link loop" in line


@pytest.mark.parametrize(("label", "data", "words"), [
    ("latin-1", 'name = "café"\n'.encode("latin-1"), ["not UTF-8", "0xe9"]),
    ("UTF-16", 'name = "x"\n'.encode("utf-16"), ["not UTF-8"]),
    ("a lone continuation byte", b'name = "\x80"\n', ["not UTF-8", "0x80"]),
    ("NUL bytes", b"name = \x00\n", ["malformed TOML"]),
    ("arrays 5000 deep", b"x = " + b"[" * 5000 + b"]" * 5000, ["too deeply"]),
    ("inline tables 3000 deep", b"x = " + b"{a = " * 3000 + b"1" + b"}" * 3000, ["too deeply"]),
    ("arrays 40 deep", b"[camera]\norigin = " + b"[" * 40 + b"]" * 40, ["camera.origin", "16 levels"]),
    ("tables 30 deep", b"[" + b".".join(b"t%d" % i for i in range(30)) + b"]\n", ["16 levels"]),
    ("a byte-order mark", '\ufeffname = "bom"\n[camera\n'.encode(), ["malformed TOML"]),
])
def test_scene_files_that_once_tracebacked(tmp_path, capsys, label, data, words):
    path = tmp_path / "bad.toml"
    path.write_bytes(data)
    line = refused(capsys, ["render", str(path)])
    assert "bad.toml" in line and all(w in line for w in words), line


def test_a_byte_order_mark_alone_is_accepted(tmp_path):
    import scenes

    path = tiny_scene(tmp_path, "bom")
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert scenes.load(path).name == "bom"


@pytest.mark.parametrize("value", ["[" * 3000 + "]" * 3000, "{a=" * 3000 + "1" + "}" * 3000, "[1.0, 2.0, 3.0" * 1000])
def test_set_values_nested_or_broken(tmp_path, capsys, value):
    line = refused(capsys, ["render", str(tiny_scene(tmp_path)), "--set", f"camera.origin={value}"])
    assert "camera.origin" in line and len(line) < 700


@pytest.mark.parametrize(("label", "line", "words"), [
    ("a list", "[1, 2, 3]", ["not an object"]),
    ("a number", "42", ["not an object"]),
    ("NaN", "NaN", ["not an object"]),
    ("missing keys", '{"id": "x"}', ["missing keys"]),
    ("wrong types", None, ["realtime_ms"]),
    ("a string psnr", None, ["psnr"]),
    ("no materials", None, ["materials"]),
    ("nested 100000 deep", "[" * 100000 + "]" * 100000, ["nested too deeply"]),
    ("not JSON", '{"id": "x", oops}', ["not JSON"]),
    ("bytes that are not UTF-8", None, ["line 2"]),
])
def test_corrupt_complete_lines_in_results(tmp_path, capsys, label, line, words):
    good = hostile.hostile_rows()[0].to_dict()
    if label == "wrong types":
        line = json.dumps({**good, "realtime_ms": 5})
    elif label == "a string psnr":
        line = json.dumps({**good, "psnr": "high"})
    elif label == "no materials":
        line = json.dumps({**good, "materials": []})
    elif label == "bytes that are not UTF-8":
        line = json.dumps({**good, "scene": "\udcff"}, ensure_ascii=False).encode("utf-8", "surrogateescape")
    body = json.dumps(good).encode() + b"\n" + (line if isinstance(line, bytes) else line.encode()) + b"\n"
    (tmp_path / RESULTS).write_bytes(body)
    if label == "bytes that are not UTF-8":  # replaced on reading: the row is valid, with U+FFFD in its name
        assert cli.main(["report", str(tmp_path)]) == 0
        return
    err = refused(capsys, ["report", str(tmp_path)])
    assert "line 2" in err and all(w in err for w in words), err


def test_a_corrupt_experiments_json_is_refused(tmp_path, capsys):
    (tmp_path / RESULTS).write_text("")
    (tmp_path / "experiments.json").write_text('{"sections": 5}')
    assert "experiments.json" in refused(capsys, ["report", str(tmp_path)])
    (tmp_path / "experiments.json").write_text("[" * 100000)
    assert "experiments.json" in refused(capsys, ["report", str(tmp_path)])


@pytest.mark.parametrize("peak", [3.4e38, 1e30, 1e21])
def test_map_values_near_the_float32_maximum_are_refused(tmp_path, capsys, peak):
    rgb = np.full((8, 16, 3), 0.5, np.float32)
    rgb[3, 4] = peak
    imageio.write_exr(tmp_path / "hot.exr", rgb)
    line = refused(capsys, ["render", str(tiny_scene(tmp_path, env=str(tmp_path / "hot.exr")))])
    assert "hot.exr" in line and "1e+20" in line and "environment.scale" in line


def test_a_scale_that_overflows_is_refused(tmp_path, capsys):
    imageio.write_exr(tmp_path / "big.exr", np.full((8, 16, 3), 1e30, np.float32))
    scene = tiny_scene(tmp_path, env=str(tmp_path / "big.exr"))
    line = refused(capsys, ["render", str(scene), "--set", "environment.scale=1e9"])
    assert "environment.scale = 1e+09" in line  # 1e39 overflows float32 to inf: refused, not rendered as NaN


@pytest.mark.gl
@pytest.mark.mitsuba
@pytest.mark.parametrize("peak", [1e20, 1e12])
def test_bright_but_accepted_maps_render_finite_in_all_three_renderers(tmp_path, monkeypatch, peak):
    import groundtruth
    import realtime
    import scenes
    from experiments.measure import metrics
    from groundtruth.exact import quadrature

    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    rgb = np.full((8, 16, 3), 0.5, np.float32)
    rgb[3, 4] = peak
    imageio.write_exr(tmp_path / "hot.exr", rgb)
    s = scenes.load(tiny_scene(tmp_path, env=str(tmp_path / "hot.exr")))
    for r in (realtime.render(s), groundtruth.render(s), quadrature.render(s, subpixels=1)):
        assert np.isfinite(r.rgb).all() and r.rgb.min() >= 0
        assert np.isfinite(metrics.display(s, r.rgb)).all()


@pytest.mark.parametrize("fov", ["1e-30", "1e-300", "5e-324", "0.0009", "-0.0", "180.0", "nan"])
def test_a_vanishing_or_impossible_field_of_view_is_refused(tmp_path, capsys, fov):
    line = refused(capsys, ["render", str(tiny_scene(tmp_path)), "--set", f"camera.fov_deg={fov}"])
    assert "camera.fov_deg" in line and "[0.001, 180)" in line


@pytest.mark.gl
def test_the_smallest_field_of_view_renders(tmp_path, capsys):
    assert cli.main(["render", str(tiny_scene(tmp_path)), "--set", "camera.fov_deg=0.001", "-o",
                     str(tmp_path / "o.exr")]) == 0
    assert np.isfinite(imageio.read_exr(tmp_path / "o.exr")).all()


@pytest.mark.parametrize(("sets", "words"), [
    (["camera.width=16384", "camera.height=16384"], ["camera.width x camera.height", "67108864"]),
    (["camera.width=16384", "camera.height=4097"], ["pixels"]),
    (["objects.0.resolution=1024"], ["override objects.0.resolution = 1024", "4190208 triangles"]),
    (["objects.0.shape=\"teapot\"", "objects.0.resolution=200"], ["teapot", "triangles"]),
    (["environment.map=\"a\\u0000b.exr\""], ["environment.map", "NUL"]),
    (["objects.0.shape=\"a\\u0000b.obj\""], ["shape", "NUL"]),
    (["objects.7.scale=2.0"], ["no object"]),
])
def test_more_of_the_class(tmp_path, capsys, sets, words):
    argv = ["render", str(tiny_scene(tmp_path))]
    for kv in sets:
        argv += ["--set", kv]
    line = refused(capsys, argv)
    assert all(w in line for w in words), line


def test_a_scene_folder_or_device_says_so(tmp_path, capsys):
    (tmp_path / "dir.toml").mkdir()
    assert "is a folder" in refused(capsys, ["render", str(tmp_path / "dir.toml")])
    assert "is a device" in refused(capsys, ["render", "/dev/null"])
    os.mkfifo(tmp_path / "fifo.toml")
    assert "named pipe" in refused(capsys, ["render", str(tmp_path / "fifo.toml")])  # never blocks reading it


def test_a_huge_scene_file_is_refused_before_parsing(tmp_path, capsys, monkeypatch):
    from scenes.model import scene

    monkeypatch.setattr(scene, "MAX_SCENE_BYTES", 100)
    path = tiny_scene(tmp_path)
    path.write_text(path.read_text() + "#" * 200)
    assert "more than the limit of 100" in refused(capsys, ["render", str(path)])


# --------------------------------------------------------------------------- Ctrl-C


@pytest.mark.gl
@pytest.mark.mitsuba
@pytest.mark.slow
def test_ctrl_c_exits_130_and_the_sweep_resumes(tmp_path):
    """SIGINT during a sweep: exit 130 with one line; rerun: every row once."""
    scene = tiny_scene(tmp_path)
    # 32 rows: enough that the signal lands while rows are still to come, however fast each one is
    cmd = [sys.executable, "-m", "experiments.cli.main", "sweep", str(scene), "--face-sizes", "1,2,4,8", "--lod-biases",
           "0,1,2,3,4,5,6,7", "--out", str(tmp_path / "sw")]
    env = {**os.environ, "PYTHONPATH": str(ROOT), "IBLCHECK_CACHE": str(tmp_path / "cache")}
    # the sweep gets Ctrl-C's default disposition whatever this process inherited (a child started with
    # SIGINT ignored, as a test runner's worker may be, never sees the interrupt)
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    results = tmp_path / "sw" / RESULTS
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:
        if results.exists() and results.read_text().count("\n") >= 1:
            break
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == 130, err
    lines = [x for x in err.splitlines() if x.startswith("error:")]
    assert len(lines) == 1 and "interrupted" in lines[0] and "Traceback" not in err
    first = [json.loads(x)["id"] for x in results.read_text().splitlines()]
    assert 1 <= len(first) < 32
    done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    ids = [json.loads(x)["id"] for x in results.read_text().splitlines()]
    assert len(ids) == len(set(ids)) == 32 and ids[: len(first)] == first


class _InterruptedImport:
    """A finder that raises KeyboardInterrupt when `name` is imported: a Ctrl-C landing in that import."""

    def __init__(self, name: str) -> None:
        self.name = name

    def find_spec(self, fullname, path=None, target=None):
        if fullname == self.name:
            raise KeyboardInterrupt
        return None


@pytest.mark.parametrize("interrupted", [True, False])
def test_ctrl_c_while_the_command_line_imports_exits_130_with_one_line(capsys, monkeypatch, interrupted):
    """The console script's entry imports the command line inside its guard: an interrupt there is one `error:`
    line and 130, as an interrupt during a command is. Control: the same entry without the interrupt runs the
    command (`--help`, 0)."""
    monkeypatch.delitem(sys.modules, "experiments.cli.main")
    monkeypatch.delattr("experiments.cli.main", raising=False)
    if interrupted:
        monkeypatch.setattr(sys, "meta_path", [_InterruptedImport("experiments.cli.main"), *sys.meta_path])
    code = entry.main(["--help"])
    captured = capsys.readouterr()
    if interrupted:
        assert code == 130 and captured.err == "error: interrupted while starting; nothing was written\n"
    else:
        assert code == 0 and "usage: iblcheck" in captured.out and captured.err == ""


class _GoneReader:
    """A stdout whose reader has gone: every write raises BrokenPipeError, as `| head -n 0` makes it."""

    def write(self, text: str) -> int:
        raise BrokenPipeError(32, "Broken pipe")

    def flush(self) -> None:
        raise BrokenPipeError(32, "Broken pipe")


def test_a_closed_stdout_pipe_is_no_internal_error(tmp_path, monkeypatch, capsys):
    """`iblcheck render ... | head -n 0`: the output is dropped, the files are written and the command ends
    with its own exit code (was 4, an internal error, before the files were written)."""
    monkeypatch.setattr(sys, "stdout", _GoneReader())
    out = tmp_path / "q.exr"
    code = cli.main(["render", "builtin:sphere-diffuse", "--renderer", "quadrature", "-o", str(out),
                     "--set", "camera.width=16", "--set", "camera.height=16"])
    assert code == 0 and out.is_file() and out.with_suffix(".png").is_file()
    assert "error" not in capsys.readouterr().err
    assert isinstance(sys.stdout, _GoneReader)  # restored


def test_no_command_names_where_the_commands_are_and_version_answers(capsys):
    assert cli.main([]) == 2
    assert capsys.readouterr().err.strip() == ("error: the following arguments are required: command; "
                                               "iblcheck --help lists the commands")
    assert cli.main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("iblcheck ")


def test_a_warning_said_once_per_command(capsys):
    """A sweep's rows repeat the same warning (each comparison's catch_warnings resets Python's registry):
    each distinct line is printed once; a different one still is."""
    show = cli._WarnOnce()
    for text in ("a: lacks occlusion", "a: lacks occlusion", "b: lacks occlusion", "a: lacks occlusion"):
        show(UserWarning(text), UserWarning, "f.py", 1)
    assert capsys.readouterr().err.splitlines() == ["warning: a: lacks occlusion", "warning: b: lacks occlusion"]


@pytest.mark.parametrize("args", [["sweep", "builtin:sphere-diffuse", "--face-sizes", ""],
                                  ["sweep", "builtin:sphere-diffuse", "--lod-biases", " , "],
                                  ["voxel-storage", "builtin:sphere-diffuse", "--resolutions", ""]])
def test_an_empty_list_option_is_refused_not_read_as_its_default(tmp_path, capsys, args):
    assert cli.main([*args, "--out", str(tmp_path / "o")]) == 2
    assert "expected at least one" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_the_entry_point_starts_without_the_renderers():
    """The guard above holds only if importing the entry (and so the `experiments` package) loads none of the slow
    imports it guards: numpy, Mitsuba, OpenGL's wrappers. A fresh interpreter lists what the import loaded.
    Control: importing the command line itself loads numpy."""
    probe = ("import sys, importlib; importlib.import_module(sys.argv[1]); "
             "print(' '.join(m for m in ('numpy', 'mitsuba', 'moderngl', 'dask') if m in sys.modules))")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}

    def loaded(module: str) -> set[str]:
        out = subprocess.run([sys.executable, "-c", probe, module], cwd=ROOT, env=env, capture_output=True,
                             text=True, timeout=120, check=True).stdout
        return set(out.split())

    assert loaded("experiments.cli.entry") == set()
    assert "numpy" in loaded("experiments.cli.main")
