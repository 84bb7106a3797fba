"""What ran is what is reported.

A technique the scene chose that has nothing to do (the scene calls for no such effect, or the
technique's `has_work` says so) is not run, said in one warning line and recorded under `not_run` in the
render's techniques and the rows' description; a choice left at the engine's default is not a choice
of the scene's and is not reported. `compare`'s table has a column for every per-frame timing key.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import realtime
import scenes
from experiments.cli import main as cli
from experiments.publish import text
from experiments.publish.text import comparison_table
from realtime.engine import technique
from realtime.engine.frame import TechniqueNotRunWarning
from tests.hard.common import write_tiny

PLANE_VIEW = {"objects.0.shape": "plane", "camera.origin": [0.0, 2.5, 2.5]}


def render_recording(scene):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        r = realtime.render(scene)
    return r, [str(w.message) for w in record if issubclass(w.category, TechniqueNotRunWarning)]


@pytest.fixture
def tiny(tmp_path):
    return scenes.load(write_tiny(tmp_path))


@pytest.mark.parametrize("overrides, key", [
    ({**PLANE_VIEW, "realtime.occlusion": "vct"}, "occlusion"),  # the case
    ({"realtime.occlusion": "vct"}, "occlusion"),  # one sphere: convex, shadows nothing
    ({"realtime.occlusion": "shadow_maps", "realtime.diffuse": "lights", "realtime.glossy": "lights"}, "occlusion"),
    ({"realtime.occlusion": "prt", "realtime.diffuse": "prt"}, "occlusion"),
])
def test_a_choice_with_nothing_to_do_is_said_and_recorded_and_changes_nothing(tiny, overrides, key):
    scene = tiny.with_overrides(overrides)
    without = scene.with_overrides({f"realtime.{key}": "none"})
    if scene.realtime.diffuse == "prt":
        pytest.importorskip("embreex")
    r, said = render_recording(scene)
    plain, said_plain = render_recording(without)
    assert len(said) == 1 and f"realtime.{key} = {getattr(scene.realtime, key)!r}" in said[0], said
    assert f"the scene calls for no {key}" in said[0] and "not run" in said[0]
    assert said_plain == []  # negative control: "none" is no choice to report
    assert r.meta["techniques"][key] == getattr(scene.realtime, key)  # what was chosen stays visible ...
    assert r.meta["techniques"]["not_run"] == {key: f"the scene calls for no {key}"}  # ... and that it did not run
    assert technique.describe(scene)["not_run"] == r.meta["techniques"]["not_run"]  # the rows' description
    np.testing.assert_array_equal(r.rgb, plain.rgb)  # the image is the image without the choice
    assert set(r.timings) == set(plain.timings)  # no timing of a technique that did not run


def test_a_choice_that_runs_is_not_reported_as_idle(tmp_path):
    """Negative control: VCT occlusion on a torus (which shadows itself) runs: its timings, no not_run."""
    scene = scenes.load(write_tiny(tmp_path)).with_overrides(VCT_TORUS)
    r, said = render_recording(scene)
    assert said == [] and "not_run" not in r.meta["techniques"] and "not_run" not in technique.describe(scene)
    assert "voxelize" in r.timings and "mip" in r.timings


@pytest.mark.parametrize("material, key", [('{ type = "diffuse" }', "glossy"), ('{ type = "phong" }', "diffuse")])
def test_an_engine_default_for_an_absent_effect_is_not_reported(tmp_path, material, key):
    """`glossy = "box"` (the default) on a diffuse-only scene is the engine's standing choice: no warning."""
    scene = scenes.load(write_tiny(tmp_path, material=material))
    assert key not in scene.effects and getattr(scene.realtime, key) != "none"
    r, said = render_recording(scene)
    assert said == [] and "not_run" not in r.meta["techniques"]
    assert technique.not_run(scene) == {}


def test_a_non_default_choice_for_an_absent_effect_is_reported(tmp_path):
    scene = scenes.load(write_tiny(tmp_path, material='{ type = "diffuse" }')).with_overrides(
        {"realtime.glossy": "prefiltered"})
    assert technique.not_run(scene) == {"glossy": "the scene calls for no glossy"}


def test_two_idle_choices_share_one_warning_line(tiny):
    scene = tiny.with_overrides({"realtime.occlusion": "vct", "realtime.interreflection": "vct"})
    r, said = render_recording(scene)
    assert len(said) == 1 and "realtime.occlusion" in said[0] and "realtime.interreflection" in said[0]
    assert set(r.meta["techniques"]["not_run"]) == {"occlusion", "interreflection"}


VCT_TORUS = {"objects.0.shape": "torus", "realtime.occlusion": "vct", "realtime.vct.resolution": 32,
             "realtime.vct.cascades": 1}


def test_a_technique_whose_hook_says_it_has_no_work_is_not_run(tiny, monkeypatch):
    """The general hook: an optional effect's technique (here VCT occlusion on a torus, patched) that says
    it has no work is neither prepared nor compiled in; the image is then the image with `occlusion = "none"`."""
    monkeypatch.setattr(technique.declaration_of("occlusion", "vct").load(), "has_work", lambda self, frame: False)
    scene = tiny.with_overrides(VCT_TORUS)
    r, said = render_recording(scene)
    assert len(said) == 1 and "realtime.occlusion = 'vct': its technique has no work in this scene" in said[0]
    assert r.meta["techniques"]["not_run"] == {"occlusion": "its technique has no work in this scene"}
    assert "voxelize" not in r.timings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        none = realtime.render(tiny.with_overrides({"objects.0.shape": "torus"}))  # occlusion = "none"
    np.testing.assert_array_equal(r.rgb, none.rgb)


@pytest.mark.mitsuba
def test_a_row_records_what_did_not_run(tmp_path, monkeypatch):
    """The row of a configuration whose technique said it had no work carries that in its techniques,
    as the render's metadata does (not only what the scene chose)."""
    from experiments.runs import rows

    monkeypatch.setattr(technique.declaration_of("occlusion", "vct").load(), "has_work", lambda self, frame: False)
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    row = rows.run_row(tmp_path / "out", str(write_tiny(tmp_path)), VCT_TORUS)
    assert row.techniques["occlusion"] == "vct"
    assert row.techniques["not_run"] == {"occlusion": "its technique has no work in this scene"}


def test_a_lobe_the_scene_calls_for_is_always_shaded(tiny, monkeypatch):
    """A diffuse or glossy lobe the scene has cannot be left out (the shading pass needs it): its
    technique is not asked, so a hook saying False changes nothing (negative control of the hook)."""
    box = technique.declaration_of("glossy", "box").load()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        before = realtime.render(tiny)
        monkeypatch.setattr(box, "has_work", lambda self, frame: False)
        after, said = render_recording(tiny)
    assert said == [] and "not_run" not in after.meta["techniques"]
    np.testing.assert_array_equal(before.rgb, after.rgb)


def test_the_hook_defaults_to_having_work(tiny):
    frame = technique.Frame(None, tiny, None, 16, 0)
    assert technique.Technique(frame).has_work(frame) is True


# -- compare's table: every per-frame timing key --------------------------------------------------


def timing_cells(table: str) -> dict[str, str]:
    header, _, *rows = table.splitlines()
    names = [h[: -len(" ms")] for h in _columns(header) if h.endswith(" ms")]
    values = rows[0].split()[-(len(names) + 3):-3]  # the timing columns sit before "ref s", "spp", "pixels"
    return dict(zip(names, values, strict=True))


def _columns(header: str) -> list[str]:
    return [c.strip() for c in header.split("  ") if c.strip()]


def test_every_per_frame_key_of_a_row_has_its_column():
    ms = {"filter": 0.0, "lights": 20.0, "shadow": 509.0, "draw": 54.0, "total": 583.0, "precompute": 12.0}
    cells = timing_cells(comparison_table([{"scene": "a", "realtime_ms": ms}]))
    assert list(cells) == ["filter", "lights", "shadow", "draw", "frame"]  # precompute is not per frame
    assert sum(float(cells[k]) for k in ("filter", "lights", "shadow", "draw")) == pytest.approx(float(cells["frame"]))


def test_rows_with_different_techniques_share_one_table():
    rows = [{"scene": "a", "realtime_ms": {"filter": 1.0, "draw": 2.0, "total": 3.0}},
            {"scene": "b", "realtime_ms": {"filter": 1.0, "voxelize": 4.0, "mip": 0.5, "draw": 2.0, "total": 7.5}},
            {"scene": "c", "realtime_ms": None}, {"scene": "d"}]
    table = comparison_table(rows)
    header = _columns(table.splitlines()[0])
    assert [h for h in header if h.endswith(" ms")] == ["filter ms", "voxelize ms", "mip ms", "draw ms", "frame ms"]
    a, b, c, d = (line.split() for line in table.splitlines()[2:])
    assert a[a.index("1.00") + 1: a.index("1.00") + 3] == ["-", "-"]  # a has no VCT keys: dashes, not zeros
    assert "4.00" in b and "0.50" in b and "7.50" in b
    assert c[0] == "c" and set(c[1:]) == {"-"} and set(d[1:]) == {"-"}


def test_a_psnr_at_the_noise_floor_is_marked_in_the_table():
    """README: a score within 1 dB of the floor is reported as at the noise floor; the table says so where
    the comparison says so (at_noise_floor), and only there."""
    rows = [{"scene": "a", "psnr": 31.99, "noise_floor_psnr": 32.34, "at_noise_floor": True},
            {"scene": "b", "psnr": 20.0, "noise_floor_psnr": 32.34, "at_noise_floor": False}]
    lines = comparison_table(rows).splitlines()
    assert lines[2].split()[:2] == ["a", "31.99*"] and lines[3].split()[:2] == ["b", "20.00"]
    assert lines[-1] == text.AT_FLOOR_NOTE
    assert text.AT_FLOOR_NOTE not in comparison_table(rows[1:])  # the control: no row at the floor, no note


def test_the_paper_methods_table_is_unchanged_in_its_timing_columns():
    """Negative control: SH9 + box have only `filter`, so the table's columns are the ones it always had."""
    table = comparison_table([{"scene": "a", "realtime_ms": {"filter": 1.0, "draw": 2.0, "total": 3.0,
                                                             "precompute": 9.0}}])
    assert [h for h in _columns(table.splitlines()[0]) if h.endswith(" ms")] == ["filter ms", "draw ms", "frame ms"]


def test_compare_prints_every_timing_key_of_its_render(tmp_path, capsys):
    """End to end: the light array with shadow maps times `lights` and `shadow`; the printed table shows
    both, and the frame is the sum of the columns printed."""
    scene = write_tiny(tmp_path, shape="torus")
    sets = ["--set", "realtime.diffuse=lights", "--set", "realtime.glossy=lights", "--set",
            "realtime.occlusion=shadow_maps", "--set", "realtime.lights.count=12", "--set", "reference.spp=4"]
    assert cli.main(["compare", str(scene), "--json", *sets]) == 0
    ms = json.loads(capsys.readouterr().out)["realtime_ms"]
    assert {"lights", "shadow"} <= set(ms)
    assert cli.main(["compare", str(scene), *sets]) == 0
    cells = timing_cells(capsys.readouterr().out.strip())
    per_frame = [k for k in ms if k not in ("total", "precompute")]
    assert set(cells) == {*per_frame, "frame"}
    parts = sum(float(cells[k]) for k in per_frame)
    assert parts == pytest.approx(float(cells["frame"]), abs=0.01 * len(per_frame) + 0.05 * float(cells["frame"]))
