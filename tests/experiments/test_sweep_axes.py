"""Sweep axes: any scene key, technique keys only where the technique runs, no duplicates,
negative values without `=`; result rows through their typed store."""

from __future__ import annotations

import json
import warnings

import pytest

import scenes
from experiments.cli import main as cli
from experiments.measure.results import ResultRow, ResultStore
from experiments.runs import sweep
from scenes import InputError


def configs(spec: str, **kw) -> list[dict]:
    axes = sweep.Axes(**{"face_sizes": [16], "lod_biases": None, **kw})
    return sweep.configurations(scenes.load(spec), axes)


def test_technique_keys_vary_only_where_the_technique_runs():
    got = configs("builtin:sphere-phong", lod_biases=[0.0, 1.0],
                  extra=[("realtime.glossy", ["box", "prefiltered"]), ("realtime.prefiltered.samples", [16, 64])])
    # the product's order, with the repeats (the bias of prefiltered rows, the samples of box rows) dropped
    assert got == [
        {"realtime.face_size": 16, "realtime.lod_bias": 0.0, "realtime.glossy": "box"},
        {"realtime.face_size": 16, "realtime.glossy": "prefiltered", "realtime.prefiltered.samples": 16},
        {"realtime.face_size": 16, "realtime.glossy": "prefiltered", "realtime.prefiltered.samples": 64},
        {"realtime.face_size": 16, "realtime.lod_bias": 1.0, "realtime.glossy": "box"},
    ]


def test_axes_a_scene_cannot_use_are_dropped_and_rows_not_repeated():
    # sphere-diffuse has no glossy effect: the glossy technique, the bias and the exponent cannot matter
    got = configs("builtin:sphere-diffuse", face_sizes=[16, 16, 32], lod_biases=[0.0, 1.0], exponents=[10.0, 100.0],
                  extra=[("realtime.glossy", ["box", "prefiltered"]), ("realtime.sh_order", [2, 4])])
    assert got == [{"realtime.face_size": s, "realtime.sh_order": o} for s in (16, 32) for o in (2, 4)]


def test_plan_validates_every_configuration_before_rendering():
    # the second configuration is invalid (a light count no polyhedron has): refused before any render
    with pytest.raises(InputError, match="realtime.lights.count"):
        sweep.plan(["builtin:sphere-phong"], sweep.Axes(face_sizes=[16], lod_biases=None,
                                                         extra=[("realtime.glossy", ["lights"]),
                                                                ("realtime.lights.count", [42, 40])]))


@pytest.mark.parametrize(("argv", "want"), [
    (["sweep", "s", "--lod-biases", "-1,0,1"], ["sweep", "s", "--lod-biases=-1,0,1"]),
    (["sweep", "s", "--lod-biases", "-.5"], ["sweep", "s", "--lod-biases=-.5"]),
    (["sweep", "s", "--axis", "realtime.lod_bias=-1,2"], ["sweep", "s", "--axis", "realtime.lod_bias=-1,2"]),
    (["gate", "s", "--min-psnr", "-3"], ["gate", "s", "--min-psnr=-3"]),
    (["sweep", "s", "--lod-biases", "--out", "x"], ["sweep", "s", "--lod-biases", "--out", "x"]),
])
def test_negative_values_need_no_equals_sign(argv, want):
    assert cli.join_negative_values(argv) == want
    if argv[0] == "sweep" and "--out" not in argv:
        args = cli.build_parser().parse_args(cli.join_negative_values(argv))
        assert cli.parse_list(args.lod_biases, float, "--lod-biases") is None or args.lod_biases.startswith("-")


def test_parse_axis():
    from experiments.cli.inputs import UsageError, parse_axis

    assert parse_axis("realtime.glossy=box,prefiltered") == ("realtime.glossy", ["box", "prefiltered"])
    assert parse_axis("realtime.lod_bias=-1,0.5") == ("realtime.lod_bias", [-1, 0.5])
    with pytest.raises(UsageError):
        parse_axis("realtime.glossy")


def row(i: int) -> ResultRow:
    return ResultRow(id=f"r{i}", spec="builtin:sphere-blend", overrides={"realtime.face_size": 16},
                     scene="sphere-blend", techniques={"diffuse": "sh", "sh_order": 2, "sh_window": "none",
                                                       "glossy": "box", "lod_bias": 0.5, "lod_mapping": "paper"},
                     materials=[{"type": "blend", "kd": [0.8] * 3, "exponent": 100.0, "f0": 0.04},
                                {"type": "diffuse", "kd": [0.5] * 3}],
                     env="builtin:uffizi", effects=["diffuse", "fresnel", "glossy"], unsimulated_effects=[],
                     width=8, height=8, face_size=16, psnr=30.0 + i, ssim=0.9, flip=0.1, rel_mse=0.01,
                     noise_floor_psnr=40.0, at_noise_floor=False, pixels=40, realtime_ms={"total": 2.0})


def test_rows_round_trip_and_record_every_material(tmp_path):
    store = ResultStore(tmp_path / "results.jsonl")
    store.append(row(0))
    store.append(row(1))
    back = store.read()
    assert back == [row(0), row(1)]
    assert [m["type"] for m in back[0].materials] == ["blend", "diffuse"]
    assert back[0].lod_bias == 0.5 and back[0].exponent == 100.0 and back[0].material == "blend"


def test_a_half_written_line_is_cut_and_a_corrupt_line_named(tmp_path):
    path = tmp_path / "results.jsonl"
    store = ResultStore(path)
    store.append(row(0))
    with open(path, "a") as f:
        f.write('{"id": "half')
    assert [r.id for r in store.read()] == ["r0"]
    assert path.read_text().endswith("\n")
    with open(path, "a") as f:
        f.write(json.dumps({"id": "x"}) + "\n")
    with pytest.raises(InputError, match="line 2"):
        store.read()


def test_relevance_follows_each_configurations_own_effects(tmp_path):
    # a material-type axis: the exponent matters to the phong rows only, f0 to none of them
    path = tmp_path / "plain.toml"
    path.write_text('[[objects]]\nshape = "sphere"\nmaterial = { type = "diffuse" }\n')
    got = configs(str(path), exponents=[10.0, 100.0], f0s=[0.5],
                  extra=[("objects.0.material.type", ["diffuse", "phong"])])
    assert got == [{"realtime.face_size": 16, "objects.0.material.type": "diffuse"},
                   {"realtime.face_size": 16, "objects.*.material.exponent": 10.0, "objects.0.material.type": "phong"},
                   {"realtime.face_size": 16, "objects.*.material.exponent": 100.0, "objects.0.material.type": "phong"}]


def test_technique_tables_vary_only_where_read():
    got = configs("builtin:sphere-diffuse", extra=[("realtime.diffuse", ["sh", "irradiance_map"]),
                                                    ("realtime.irradiance_map.size", [16, 32])])
    assert got == [{"realtime.face_size": 16, "realtime.diffuse": "sh"},
                   {"realtime.face_size": 16, "realtime.diffuse": "irradiance_map", "realtime.irradiance_map.size": 16},
                   {"realtime.face_size": 16, "realtime.diffuse": "irradiance_map", "realtime.irradiance_map.size": 32}]


def test_technique_axes_come_from_the_techniques_declarations():
    import math

    from realtime.engine import technique

    got = configs("builtin:sphere-diffuse", technique_axes=True)
    # every diffuse technique, each with the product of its own declared axes (sphere-diffuse is convex:
    # no occlusion or interreflection techniques)
    want = sum(math.prod(len(v) for v in technique.declaration_of(key, value).axes.values())
               for key, value in technique.pairs() if key == "diffuse")
    assert len(got) == want
    assert {c["realtime.diffuse"] for c in got} == {v for k, v in technique.pairs() if k == "diffuse"}
    assert all(("realtime.sh_order" in c) == (c["realtime.diffuse"] == "sh") for c in got)
    assert not any("realtime.glossy" in c for c in got)  # sphere-diffuse has no glossy effect


@pytest.mark.parametrize(("text", "want"), [
    ("camera.origin=[0,0,4],[0,0,6]", ("camera.origin", [[0, 0, 4], [0, 0, 6]])),
    ('environment.map="a,b.exr",builtin:uffizi', ("environment.map", ["a,b.exr", "builtin:uffizi"])),
])
def test_axis_values_may_hold_commas_inside_brackets_and_quotes(text, want):
    from experiments.cli.inputs import parse_axis

    assert parse_axis(text) == want


def test_technique_axes_on_a_scene_with_occlusion_make_only_valid_configurations():
    """Occlusion and interreflection bring choices that need each other (shadow maps need the light array,
    interreflected transfer needs bounces): the generated plan holds only configurations the scene model
    accepts (sweep.plan validates every one) and still holds each kind."""
    got = sweep.plan(["builtin:sphere-on-plane"], sweep.Axes(face_sizes=None, lod_biases=None, technique_axes=True))
    kinds = {(ov.get("realtime.diffuse"), ov.get("realtime.occlusion"), ov.get("realtime.interreflection"))
             for _, ov in got}
    assert {("lights", "shadow_maps", "none"), ("prt", "prt", "prt"), ("prt", "prt", "none"), ("sh", "none", "none"),
            ("sh", "vct", "vct")} <= kinds
    assert ("sh", "shadow_maps", "none") not in kinds and ("sh", "prt", "none") not in kinds
    bounces = {ov.get("realtime.prt.bounces") for _, ov in got if ov.get("realtime.interreflection") == "prt"}
    assert bounces == {1, 2}


def test_an_axis_that_changes_nothing_in_a_scene_is_said_once():
    """sphere-diffuse has no glossy effect: its LOD bias and exponent axes are left out of its rows (README),
    and a warning says so; on sphere-blend the same axes are kept and nothing is said."""
    axes = sweep.Axes(face_sizes=[32], lod_biases=[0.0, 1.0, 2.0], exponents=[10.0, 20.0])
    with pytest.warns(sweep.UnusedAxisWarning, match=r"builtin:sphere-diffuse: realtime.lod_bias, "
                                                     r"objects.\*.material.exponent change nothing"):
        assert len(sweep.plan(["builtin:sphere-diffuse"], axes)) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", sweep.UnusedAxisWarning)
        assert len(sweep.plan(["builtin:sphere-blend"], axes)) == 6
