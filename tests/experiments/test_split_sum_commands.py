"""The split sum through the command line: every recipe in `compare`, the recipe axis in `sweep
--technique-axes`, and `gate` on a glTF scene (tiny images: these check that the commands run it and
report what ran, not its accuracy, which E11 measures)."""

from __future__ import annotations

import json

import pytest

from experiments.cli import main as cli
from experiments.measure.results import store_in

pytestmark = [pytest.mark.gl, pytest.mark.mitsuba]

TINY = ["--set", "camera.width=24", "--set", "camera.height=24", "--set", "reference.spp=16",
        "--set", "realtime.timing_frames=1", "--set", "realtime.warmup_frames=0", "--set", "realtime.split_sum.size=16",
        "--set", "realtime.base_size=16", "--set", "realtime.face_size=16"]
SCENE = """name = "pbr-sphere"
[environment]
map = "builtin:uffizi"
[camera]
origin = [0.0, 0.0, 4.0]
fov_deg = 32.0
[realtime]
glossy = "split_sum"
[[objects]]
shape = "sphere"
material = { type = "pbr", base_color = [0.9, 0.6, 0.3], metallic = 0.5, roughness = 0.4 }
"""
#: each engine's DFG table size and sample count as its own code publishes them (Khronos' ibl_sampler.js
#: lutResolution, Filament's DFG.h, three.js' DFGApprox / generateDFGLUT.js, Babylon's shipped 256^2 PNG)
PUBLISHED_LUT = {"khronos": 1024, "filament": 128, "threejs": 16, "babylon": 256}


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "pbr-sphere.toml"
    path.write_text(SCENE)
    return str(path)


@pytest.mark.slow
@pytest.mark.parametrize("recipe", sorted(PUBLISHED_LUT))
def test_compare_and_render_run_each_recipe_and_report_what_ran(capsys, tmp_path, scene_file, recipe):
    chosen = ["--set", f"realtime.split_sum.recipe={recipe}"]
    assert cli.main(["compare", scene_file, "--json", *TINY, *chosen]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["psnr"] is not None and {"prefilter", "precompute", "total"} <= set(result["realtime_ms"])
    assert cli.main(["render", scene_file, "-o", str(tmp_path / "t.exr"), *TINY, *chosen]) == 0
    settings = json.loads(capsys.readouterr().out)["techniques"]
    assert settings["glossy"] == "split_sum" and settings["split_sum"]["recipe"] == recipe
    assert settings["split_sum"]["lut_size"] == PUBLISHED_LUT[recipe]
    assert settings["split_sum"]["size"] == 16  # the override wins over the recipe's


def test_a_custom_recipe_without_every_key_exits_2_naming_them(capsys, scene_file):
    assert cli.main(["compare", scene_file, *TINY, "--set", "realtime.split_sum.recipe=custom"]) == 2
    err = capsys.readouterr().err
    assert "realtime.split_sum.recipe = 'custom'" in err and "realtime.split_sum.sampling" in err


@pytest.mark.slow
def test_sweep_technique_axes_vary_the_recipe(tmp_path, scene_file):
    out = tmp_path / "sweep"
    assert cli.main(["sweep", scene_file, "--technique-axes", "--out", str(out), *TINY]) == 0
    rows = store_in(out).read()
    recipes = {r.techniques["split_sum"]["recipe"] for r in rows if r.techniques.get("glossy") == "split_sum"}
    assert recipes == set(PUBLISHED_LUT)


def test_gate_passes_and_fails_a_glTF_scene_by_its_threshold(tmp_path, scene_file):
    """The same scene passes a bound it clears and fails one it cannot (a PSNR of 99 dB)."""
    assert cli.main(["gate", scene_file, "--min-psnr", "5", *TINY]) == 0
    assert cli.main(["gate", scene_file, "--min-psnr", "99", *TINY]) == 1
