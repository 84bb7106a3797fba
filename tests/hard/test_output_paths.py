"""Nothing is written outside where the user asked.

Default output names are slugs of the scene name in the working directory; every output path is checked
before anything renders (exit 2, one `error:` line); writes are atomic and leave no temporary file on
any failure, Ctrl-C included; folders made for a command that then fails are removed again.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from experiments.cli import main as cli
from experiments.cli import render_cmd
from experiments.paper.e06_hostile_runs import tiny_scene
from experiments.publish import outputs
from scenes.storage import files, imageio

SLUGS = [("../../x", "x"), ("/etc/passwd", "etc-passwd"), ("..", "scene"), (".", "scene"), ("", "scene"),
         (".hidden", "hidden"), ("a/b\\c", "a-b-c"), ("\x1b[31mred\x1b[0m", "31mred-0m"), ("--help", "help"),
         ("name with spaces", "name-with-spaces"), ("Café ñandú", "Cafe-nandu"), ("名前", "scene"),
         ("x" * 300, "x" * 64), ("a..b", "a.b"), ("CON", "CON"), ("sphere-blend", "sphere-blend"),
         ("<img src=x onerror=alert(1)>", "img-src-x-onerror-alert-1")]


@pytest.mark.parametrize(("name", "want"), SLUGS, ids=[f"slug{i}" for i in range(len(SLUGS))])
def test_slug(name, want):
    out = outputs.slug(name)
    assert out == want
    assert "/" not in out and not out.startswith(".") and ".." not in out and 0 < len(out) <= 64


@pytest.fixture
def no_render(monkeypatch):
    """Fail the test if a command gets as far as rendering."""
    def refuse(*a, **k):
        raise AssertionError("rendered before the output path was checked")

    monkeypatch.setattr(render_cmd, "render_with", refuse)
    from experiments.measure import comparison
    from experiments.runs import gate

    monkeypatch.setattr(comparison, "run", refuse)
    monkeypatch.setattr(gate, "measure", refuse)  # compare and gate measure through it


def leftovers(folder: Path) -> list[str]:
    return sorted(str(p) for p in folder.rglob("*") if ".tmp" in p.name or p.name.startswith(".iblcheck-probe"))


def one_error(capsys, code: int) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("error: "), (code, err)
    return err[0]


@pytest.mark.gl
@pytest.mark.parametrize("name", ["../../escape", "/tmp/abs", "../x/../../y", "\x1b]0;t\x07", "..", "a" * 250])
def test_render_without_o_writes_only_a_slug_in_the_working_directory(tmp_path, monkeypatch, capsys, name):
    work = tmp_path / "a" / "b" / "work"
    work.mkdir(parents=True)
    scene = tiny_scene(tmp_path / "a", name)
    monkeypatch.chdir(work)
    assert cli.main(["render", str(scene)]) == 0, capsys.readouterr().err
    stem = outputs.slug(name)
    assert sorted(os.listdir(work)) == [f"{stem}-realtime.exr", f"{stem}-realtime.png"]
    written = {p for p in tmp_path.rglob("*") if p.is_file()} - {scene}
    assert written == {work / f"{stem}-realtime.exr", work / f"{stem}-realtime.png"}
    assert not Path("/tmp/abs-realtime.exr").exists()


BAD_OUTPUTS = [  # (label, how to make it, args after the scene, words in the error)
    ("parent is a file", lambda f: (f / "file").write_text("x"), ["-o", "{f}/file/out.exr"], ["-o", "Not a directory"]),
    ("deep parent under a file", lambda f: (f / "file").write_text("x"), ["-o", "{f}/file/a/b/out.exr"], ["-o"]),
    ("a folder", lambda f: (f / "dir.exr").mkdir(), ["-o", "{f}/dir.exr"], ["is a folder"]),
    ("its png a folder", lambda f: (f / "out.png").mkdir(), ["-o", "{f}/out.exr"], ["out.png", "is a folder"]),
    ("a named pipe", lambda f: os.mkfifo(f / "p.exr"), ["-o", "{f}/p.exr"], ["not a regular file"]),
    ("in /proc", None, ["-o", "/proc/iblcheck-test/out.exr"], ["/proc", "cannot be created"]),
    ("at /proc's top", None, ["-o", "/proc/out.exr"], ["/proc", "cannot write"]),
    ("in read-only /sys", None, ["-o", "/sys/out.exr"], ["/sys", "cannot write"]),
    ("a loop of links", lambda f: os.symlink(f / "d", f / "d"), ["-o", "{f}/d/out.exr"], ["-o"]),
    ("not .exr", None, ["-o", "{f}/out.png"], [".exr"]),
    ("only a folder name", None, ["-o", "{f}/"], ["-o"]),
    ("the scene's own map", lambda f: imageio.write_exr(f / "own.exr", np.ones((4, 8, 3), np.float32)),
     ["-o", "{f}/own.exr", "--set", "environment.map={f}/own.exr"], ["overwrite", "input"]),
]


@pytest.mark.parametrize(("label", "make", "args", "words"), BAD_OUTPUTS, ids=[b[0] for b in BAD_OUTPUTS])
def test_bad_render_outputs_refused_before_rendering(tmp_path, capsys, no_render, label, make, args, words):
    f = tmp_path / "out"
    f.mkdir()
    if make:
        make(f)
    scene = tiny_scene(tmp_path)
    line = one_error(capsys, cli.main(["render", str(scene), *[a.format(f=f) for a in args]]))
    for w in words:
        assert w in line, line
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize(("label", "args", "words"), [
    ("gate --junit a folder", ["gate", "{s}", "--min-psnr", "1", "--junit", "{f}"], ["--junit", "is a folder"]),
    ("gate --junit in /proc", ["gate", "{s}", "--min-psnr", "1", "--junit", "/proc/x/g.xml"], ["--junit", "/proc"]),
    ("gate --junit under a file", ["gate", "{s}", "--min-psnr", "1", "--junit", "{s}/g.xml"], ["--junit"]),
    ("sweep --out a file", ["sweep", "{s}", "--out", "{s}"], ["--out", "is a file"]),
    ("sweep --out in /proc", ["sweep", "{s}", "--out", "/proc/iblcheck-x"], ["--out", "/proc"]),
    ("sweep --out in /sys", ["sweep", "{s}", "--out", "/sys/iblcheck-x"], ["--out", "/sys"]),
    ("paper --out a file", ["paper", "--quick", "--out", "{s}"], ["--out", "is a file"]),
    ("paper --out in /proc", ["paper", "--quick", "--out", "/proc/iblcheck-x"], ["--out", "/proc"]),
    ("report of a file", ["report", "{s}"], ["results.jsonl", "not found"]),
    ("report of a missing folder", ["report", "{f}/missing"], ["not found"]),
])
def test_bad_outputs_of_other_commands_refused_before_work(tmp_path, capsys, no_render, label, args, words):
    scene = tiny_scene(tmp_path)
    line = one_error(capsys, cli.main([a.format(s=scene, f=tmp_path) for a in args]))
    for w in words:
        assert w in line, line
    assert leftovers(tmp_path) == []
    assert not (tmp_path / "missing").exists()


def test_report_into_a_folder_whose_index_is_a_folder(tmp_path, capsys):
    (tmp_path / "results.jsonl").write_text("")
    (tmp_path / "index.html").mkdir()
    line = one_error(capsys, cli.main(["report", str(tmp_path)]))
    assert "index.html" in line and "is a folder" in line


def test_a_folder_made_for_a_failed_command_is_removed(tmp_path, capsys, monkeypatch):
    def broken(renderer, scene):
        raise render_cmd.UsageError("the render failed")

    monkeypatch.setattr(render_cmd, "render_with", broken)
    one_error(capsys, cli.main(["render", str(tiny_scene(tmp_path)), "-o", str(tmp_path / "new/deeper/out.exr")]))
    assert not (tmp_path / "new").exists()


@pytest.mark.parametrize("failure", [OSError(28, "No space left on device"), KeyboardInterrupt(), RuntimeError("x")])
def test_atomic_output_leaves_no_temporary_file_and_keeps_the_old_one(tmp_path, failure):
    target = tmp_path / "out.bin"
    target.write_bytes(b"old")
    with pytest.raises(type(failure)), files.atomic_output(target) as tmp:
        tmp.write_bytes(b"half")
        raise failure
    assert target.read_bytes() == b"old" and sorted(os.listdir(tmp_path)) == ["out.bin"]


def test_atomic_output_mode_follows_the_umask(tmp_path):
    files.write_bytes(tmp_path / "a", b"x")
    assert (tmp_path / "a").stat().st_mode & 0o777 == files.output_mode()


def test_exr_write_interrupted_leaves_nothing(tmp_path, monkeypatch):
    import OpenEXR

    def interrupted(self, path):
        Path(path).write_bytes(b"partial")
        raise KeyboardInterrupt

    monkeypatch.setattr(OpenEXR.File, "write", interrupted)
    with pytest.raises(KeyboardInterrupt):
        imageio.write_exr(tmp_path / "x.exr", np.ones((2, 2, 3), np.float32))
    assert os.listdir(tmp_path) == []


@pytest.mark.gl
def test_render_interrupted_while_writing_leaves_no_file(tmp_path, capsys, monkeypatch):
    from experiments.publish import images

    def interrupted(path, rgb01):
        raise KeyboardInterrupt

    monkeypatch.setattr(images, "save_png", interrupted)
    assert cli.main(["render", str(tiny_scene(tmp_path)), "-o", str(tmp_path / "o" / "x.exr")]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert leftovers(tmp_path) == []  # the EXR was complete (written first, atomically), the PNG never started
    assert not (tmp_path / "o" / "x.png").exists()
