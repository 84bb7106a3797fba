"""An output file typed with a trailing separator names a folder and is refused, whatever its suffix.

`pathlib.Path("out.exr/")` is `out.exr`: the slash is lost before any check could see it, so the text as
typed is checked (experiments/publish/outputs.py `file_path`). Exit 2, one `error:` line naming the
path, nothing rendered or written.
"""

from __future__ import annotations

import pytest

from experiments.cli import main as cli
from experiments.paper.e06_hostile_runs import tiny_scene
from experiments.publish import outputs
from tests.hard.test_output_paths import leftovers, no_render, one_error  # noqa: F401  (no_render: a fixture)

SLASHED = ["out2.exr/", "newout/", "a/b/c.exr/", "x.exr//", "deep/new/out.EXR/"]


@pytest.mark.parametrize("typed", SLASHED)
def test_render_o_with_a_trailing_slash_is_refused_alike(tmp_path, capsys, no_render, typed):  # noqa: F811
    scene = tiny_scene(tmp_path)
    target = f"{tmp_path}/{typed}"
    line = one_error(capsys, cli.main(["render", str(scene), "-o", target]))
    assert "-o" in line and target in line and "names a folder" in line, line
    assert leftovers(tmp_path) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == [scene.name]  # no folder or file was made


@pytest.mark.parametrize("flag", ["--junit", "--markdown", "--write-baseline"])
def test_gate_files_with_a_trailing_slash_are_refused(tmp_path, capsys, no_render, flag):  # noqa: F811
    scene = tiny_scene(tmp_path)
    target = f"{tmp_path}/report.xml/"
    line = one_error(capsys, cli.main(["gate", str(scene), "--min-psnr", "1", flag, target]))
    assert flag in line and target in line and "names a folder" in line, line


def test_file_path_keeps_plain_names():
    """Negative control: a path without a trailing separator is the same Path."""
    assert outputs.file_path("out/x.exr", "-o") == outputs.Path("out/x.exr")
    assert outputs.file_path(outputs.Path("x.exr"), "-o") == outputs.Path("x.exr")
    with pytest.raises(outputs.UsageError, match="names a folder"):
        outputs.file_path("x.exr/", "-o")


@pytest.mark.gl
def test_render_o_without_slash_still_writes(tmp_path, capsys):
    """Negative control: the same path without the slash renders and writes the EXR and PNG."""
    scene = tiny_scene(tmp_path)
    assert cli.main(["render", str(scene), "-o", str(tmp_path / "o" / "out2.exr")]) == 0, capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["out2.exr", "out2.png"]
