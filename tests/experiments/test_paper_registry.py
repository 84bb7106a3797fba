"""The paper suite's experiments (experiments/paper/registry.py): one shape each, found by number, run in
number order, `paper --only` for a subset (resuming rows, keeping the other experiments' sections), and E7's
ladder points of plugin techniques. No OpenGL or Mitsuba: the rows here are stand-ins."""

from __future__ import annotations

import dataclasses
import inspect
import json
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from experiments.cli.main import main
from experiments.measure.results import store_in
from experiments.paper import context as context_mod
from experiments.paper import e07_accuracy_time_ladder as e7
from experiments.paper import registry, suite
from experiments.paper.e06_hostile_cases import hostile_rows
from experiments.publish.report import Section, paragraph
from experiments.runs.sweep import row_id

PAPER = Path(__file__).resolve().parents[2] / "experiments" / "paper"


# ----------------------------------------------------------------------------- the shape


def test_every_experiment_file_is_registered_once_in_number_order():
    # an experiment's parts (e06_hostile_*, e08_sharp_*, e10_voxel_storage, ...) share its number but declare no
    # NUMBER of their own: read from the source, so that a module that does and is not registered fails here
    files = sorted(p.stem for p in PAPER.glob("e[0-9][0-9]_*.py")
                   if re.search(r"^NUMBER = ", p.read_text(), re.MULTILINE))
    assert [m.__name__.rsplit(".", 1)[1] for m in registry.EXPERIMENTS] == files
    assert [m.NUMBER for m in registry.EXPERIMENTS] == list(range(1, 13))
    assert registry.names() == [f"E{n}" for n in range(1, 13)]


@pytest.mark.parametrize("module", registry.EXPERIMENTS, ids=registry.name)
def test_every_experiment_has_the_same_small_entry(module):
    stem = module.__name__.rsplit(".", 1)[1]
    assert int(stem[1:3]) == module.NUMBER  # the file is found by the number
    assert module.TITLE.startswith(f"E{module.NUMBER} ")
    assert dataclasses.is_dataclass(module.Settings) and module.Settings.__dataclass_params__.frozen
    for settings in (module.QUICK, module.FULL):
        assert isinstance(settings, module.Settings)
    assert list(inspect.signature(module.run).parameters) == ["context", "settings"]
    assert list(inspect.signature(module.count_steps).parameters) == ["settings"]


@pytest.mark.parametrize("module", [m for m in registry.EXPERIMENTS if m.NUMBER != 8], ids=registry.name)
def test_step_counts_are_positive_and_full_is_no_smaller_than_quick(module):
    quick, full = module.count_steps(module.QUICK), module.count_steps(module.FULL)
    assert isinstance(quick, int) and 0 < quick <= full


# ----------------------------------------------------------------------------- names


@pytest.mark.parametrize(("text", "number"), [("E8", 8), ("e8", 8), ("E08", 8), (" e010 ", 10), ("E1", 1)])
def test_names_find_experiments_case_insensitively(text, number):
    assert registry.find(text).NUMBER == number


@pytest.mark.parametrize("text", ["E13", "E0", "8", "E", "E8,E9", "Ex", ""])
def test_other_names_find_nothing(text):
    assert registry.find(text) is None


def test_select_keeps_number_order_and_names_the_unknown():
    assert [m.NUMBER for m in registry.select(["E10", "e8", "E08"])] == [8, 10]
    with pytest.raises(ValueError, match=r"'E13' is no experiment; valid: E1, E2, .*, E12"):
        registry.select(["E8", "E13"])


def test_paper_only_with_an_unknown_name_exits_2_naming_the_flag_the_value_and_the_valid_ones(capsys, tmp_path):
    assert main(["paper", "--quick", "--only", "E8,E13", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: argument --only: 'E13'") and "E1, E2" in err and "E12" in err
    assert len(err.splitlines()) == 1
    assert not (tmp_path / "out").exists()  # refused before anything ran


# ----------------------------------------------------------------------------- subset runs


def fake_experiment(number: int, specs: tuple[str, ...]):
    """An experiment of the registry's shape whose rows are `context.row` of `specs` (rendered by the
    stand-in run_row below) and whose section names the rows' ids."""

    @dataclasses.dataclass(frozen=True)
    class Settings:
        n: int

    def run(context, settings):
        rows = [context.row(spec, {"realtime.face_size": settings.n}, f"E{number}") for spec in specs]
        text = f"E{number} rows " + " ".join(r.id for r in rows)
        return Section(f"E{number} fake", [paragraph(text)], text)

    return SimpleNamespace(NUMBER=number, TITLE=f"E{number} fake", Settings=Settings, QUICK=Settings(8),
                           FULL=Settings(16), count_steps=lambda settings: len(specs), run=run)


@pytest.fixture
def fakes(monkeypatch):
    """Two fake experiments E1 and E2 as the registry, rows made without rendering; `computed` lists
    the rows computed (not reused)."""
    computed = []
    template = hostile_rows()[0]

    def run_row(out, spec, ov, experiment, convergence_curve=None, references=None):
        computed.append(spec)
        return dataclasses.replace(template, id=row_id(spec, ov), spec=spec, overrides=ov, scene=spec,
                                   experiment=experiment, images={})

    monkeypatch.setattr(context_mod, "run_row", run_row)
    one = fake_experiment(1, ("builtin:sphere-diffuse", "builtin:sphere-phong"))
    two = fake_experiment(2, ("builtin:sphere-blend",))
    monkeypatch.setattr(registry, "EXPERIMENTS", (one, two))
    return SimpleNamespace(one=one, two=two, computed=computed)


def titles(out: Path) -> list[str]:
    return re.findall(r"^## (E\d+ fake)$", (out / "summary.md").read_text(), re.MULTILINE)


def test_a_subset_run_reuses_rows_and_keeps_the_other_experiments_sections(fakes, tmp_path):
    out = tmp_path / "paper"
    suite.run(out, quick=True)
    assert len(fakes.computed) == 3 and titles(out) == ["E1 fake", "E2 fake"]
    all_ids = {r.id for r in store_in(out).read()}
    suite.run(out, quick=True, only=[fakes.two])
    assert len(fakes.computed) == 3  # E2's row reused, nothing computed again
    assert {r.id for r in store_in(out).read()} == all_ids  # E1's rows kept
    assert titles(out) == ["E1 fake", "E2 fake"]  # E1's section kept, in number order
    meta = json.loads((out / "experiments.json").read_text())
    assert [s["experiment"] for s in meta["sections"]] == ["E1", "E2"]
    assert "E1 as an earlier run in this folder left them" in meta["subtitle"]
    assert "this run (E2)" in meta["subtitle"] and "reusing 1 of 1" in meta["subtitle"]


def test_a_subset_run_after_a_run_of_the_other_kind_shows_only_its_own_sections_and_says_so(fakes, tmp_path):
    out = tmp_path / "paper"
    suite.run(out, quick=True)
    suite.run(out, quick=False, only=[fakes.two])  # full: other rows (face size 16), computed
    assert len(fakes.computed) == 4
    assert titles(out) == ["E2 fake"]
    assert "earlier run was a quick one" in json.loads((out / "experiments.json").read_text())["subtitle"]


def test_sections_saved_before_they_named_their_experiment_are_found_by_title(fakes, tmp_path):
    out = tmp_path / "paper"
    suite.run(out, quick=True)
    meta = json.loads((out / "experiments.json").read_text())
    for s in meta["sections"]:
        del s["experiment"]  # as a run before the registry wrote it
    (out / "experiments.json").write_text(json.dumps(meta))
    suite.run(out, quick=True, only=[fakes.two])
    assert titles(out) == ["E1 fake", "E2 fake"]


def test_a_run_of_every_experiment_keeps_only_its_own_rows(fakes, tmp_path):
    out = tmp_path / "paper"
    suite.run(out, quick=True)
    suite.run(out, quick=False)
    assert len(fakes.computed) == 6
    assert {r.overrides["realtime.face_size"] for r in store_in(out).read()} == {16}


# ----------------------------------------------------------------------------- E7 and plugin techniques


def declaration(name: str, effect: str, builtin: bool, ladder: tuple[dict, ...]):
    return SimpleNamespace(name=name, effect=effect, builtin=builtin, ladder=ladder)


DECLARATIONS = (declaration("sh", "diffuse", True, ({"realtime.sh_order": 2},)),
                declaration("toon", "diffuse", False, ({"realtime.toon.bands": 2}, {"realtime.toon.bands": 4})),
                declaration("aniso", "glossy", False, ({"realtime.aniso.ratio": 0.5},)),
                declaration("ao", "occlusion", False, ({"realtime.ao.rays": 8},)))


def test_plugin_points_are_the_non_builtin_ladders_with_their_technique_chosen():
    assert e7.plugin_points(DECLARATIONS) == [
        ("diffuse", {"realtime.diffuse": "toon", "realtime.toon.bands": 2}),
        ("diffuse", {"realtime.diffuse": "toon", "realtime.toon.bands": 4}),
        ("glossy", {"realtime.glossy": "aniso", "realtime.aniso.ratio": 0.5}),
        ("occlusion", {"realtime.occlusion": "ao", "realtime.ao.rays": 8})]
    assert e7.plugin_points(()) == []


def test_plugin_points_come_from_the_technique_registry(monkeypatch):
    monkeypatch.setattr(e7, "technique_registry", SimpleNamespace(declarations=lambda: DECLARATIONS))
    assert len(e7.plugin_points()) == 4
    monkeypatch.setattr(e7, "technique_registry", SimpleNamespace(declarations=lambda: DECLARATIONS[:1]))
    assert e7.plugin_points() == []  # builtins only: nothing added


def test_e7_adds_plugin_points_on_the_scenes_of_their_effect_and_leaves_builtin_rows_alone(monkeypatch):
    s = e7.QUICK
    plugins = e7.plugin_points(DECLARATIONS)
    added = {}
    for label, spec, ov in e7.scene_list():
        builtin, both = e7.configs_for(label, s), e7.configs_for(label, s, plugins)
        assert both[:len(builtin)] == builtin  # the same builtin rows, in the same order
        assert [row_id(spec, {**ov, **c}) for c in both[:len(builtin)]] == [row_id(spec, {**ov, **c}) for c in builtin]
        added[label] = both[len(builtin):]
    toon = [p for e, p in plugins if e == "diffuse"]
    aniso = [p for e, p in plugins if e == "glossy"]
    assert added == {"sphere-diffuse": toon, "sphere-phong N=10": aniso, "sphere-phong N=100": aniso,
                     "sphere-phong N=1000": aniso, "sphere-blend": aniso, "sphere-sky (sun 1e4)": [], e7.PBR_LABEL: []}
    without = e7.count_steps(s)
    monkeypatch.setattr(e7, "technique_registry", SimpleNamespace(declarations=lambda: DECLARATIONS))
    assert e7.count_steps(s) == without + 2 + 4  # two toon points on one scene, one aniso point on four
