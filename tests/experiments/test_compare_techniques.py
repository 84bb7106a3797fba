"""`compare` and `render` report the techniques, the unsimulated effects (with a warning line) and
the unbiased PSNR (docs/contract.md section 9)."""

from __future__ import annotations

import json

import pytest

from experiments.cli import main as cli

pytestmark = [pytest.mark.gl, pytest.mark.mitsuba]

TINY = ["--set", "camera.width=24", "--set", "camera.height=24", "--set", "reference.spp=16",
        "--set", "realtime.timing_frames=1", "--set", "realtime.warmup_frames=0"]


@pytest.mark.parametrize(("spec", "missing"), [("builtin:teapot-blend", ["interreflection", "occlusion"]),
                                               ("builtin:sphere-blend", [])])
def test_compare_json_names_unsimulated_effects(capsys, spec, missing):
    assert cli.main(["compare", spec, "--json", *TINY]) == 0
    out = capsys.readouterr()
    result = json.loads(out.out)
    assert result["unsimulated_effects"] == missing
    # one line saying what the compared images miss: the path-traced reference has both effects
    warned = [line for line in out.err.splitlines() if line.startswith("warning:") and "real-time image lacks" in line]
    assert len(warned) == (1 if missing else 0)
    assert "calls for" not in out.err  # the real-time side's own warning is held back by the comparison
    if missing:
        assert all(effect in warned[0] for effect in missing)
    assert result["psnr_unbiased"] is not None and isinstance(result["psnr_unbiased_clamped"], bool)
    assert {"filter", "draw", "total", "precompute"} <= set(result["realtime_ms"])


def test_render_json_line_names_the_techniques(capsys, tmp_path):
    out = tmp_path / "t.exr"
    assert cli.main(["render", "builtin:sphere-phong", "-o", str(out), *TINY, "--set", "realtime.glossy=prefiltered",
                     "--set", "realtime.prefiltered.samples=16"]) == 0
    line = json.loads(capsys.readouterr().out)
    assert line["techniques"]["glossy"] == "prefiltered" and line["techniques"]["prefiltered"]["samples"] == 16
    assert line["unsimulated_effects"] == [] and "prefilter" in line["timings_ms"]


def test_not_implemented_technique_exits_2(capsys, monkeypatch):
    import scenes.model.scene as scene_module  # every value is built today: mark one as the next unbuilt technique

    monkeypatch.setattr(scene_module, "NOT_IMPLEMENTED", frozenset({("glossy", "lights")}))
    assert cli.main(["compare", "builtin:sphere-blend", "--set", "realtime.glossy=lights", *TINY]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "not implemented yet" in err[0]


def test_compare_prints_the_table_of_its_json(capsys):
    """Without --json, `compare` prints the human table of the same numbers (publish.text.comparison_table)."""
    assert cli.main(["compare", "builtin:sphere-blend", "--json", *TINY]) == 0
    result = json.loads(capsys.readouterr().out)
    assert cli.main(["compare", "builtin:sphere-blend", *TINY]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:3] == ["scene", "PSNR", "dB"] and set(lines[1]) == {"-", " "}
    mark = "*" if result["at_noise_floor"] else ""  # a PSNR at the noise floor is marked (text.AT_FLOOR_NOTE)
    assert lines[2].split()[0] == "sphere-blend" and f"{result['psnr']:.2f}{mark}" in lines[2].split()
