"""E10's plan and measurements (experiments/paper/e10_voxel_cone_tracing.py), small: the grid, the step count the paper
suite's progress bar uses, the memory comparison, and the thin-wall leak measured (GL)."""

from __future__ import annotations

import dataclasses

import pytest

from experiments.paper import e10_voxel_cone_tracing as e10


@pytest.mark.parametrize("spec", [spec for _, spec in e10.SCENES])
def test_configs_are_direct_then_occlusion_and_interreflection_per_setting_then_the_ladder(spec):
    import scenes

    cs = e10.configs(e10.QUICK, spec)
    assert cs[0] == {}
    n = 2 * len(e10.QUICK.grid)
    vct_rows, ladder = cs[1:1 + n], cs[1 + n:]
    for a, b in zip(vct_rows[0::2], vct_rows[1::2], strict=True):
        assert a["realtime.occlusion"] == "vct" and "realtime.interreflection" not in a
        assert b == {**a, "realtime.interreflection": "vct"}
    # the ladder: PRT with a bounce where the scene has diffuse light, the light array with shadow maps always
    diffuse = "diffuse" in scenes.load(spec).effects
    assert [c.get("realtime.diffuse") == "prt" for c in ladder] == ([True] if diffuse else []) + [False]
    assert ladder[-1]["realtime.occlusion"] == "shadow_maps"
    for c in cs:  # every configuration is a valid scene
        scenes.load(spec).with_overrides(c)


def test_count_steps_matches_the_progress_calls():
    s = e10.QUICK
    # per scene: the convergence curve, one row per configuration, the energy tables; then the leak; then the
    # storage comparison, one step per atrium and resolution
    storage = len(s.storage.sizes) * len(s.storage.resolutions)
    assert e10.count_steps(s) == sum(1 + len(e10.configs(s, spec)) + 1 for _, spec in e10.SCENES) + 1 + storage


def test_memory_cascades_against_one_texture():
    one, single_one = e10.memory("builtin:cornell-open", 64, 1)
    assert one == single_one  # one cascade is the plain 3D texture
    three, single = e10.memory("builtin:cornell-open", 64, 3)
    assert three == 3 * one and single > 20 * three  # 256^3 against three 64^3


@pytest.mark.gl
def test_thin_wall_leak_is_measured():
    (x,) = e10.thin_wall_leak((16,), offsets=2)
    assert x["outside"] > 0 and 0 <= x["inside"] < x["outside"]
    assert x["leak"] == pytest.approx(x["inside"] / x["outside"])
    assert min(x["leak"], x["leak_mean"]) <= x["leak_mean"] <= x["leak_max"] and x["placements"] == 2
    assert x["visibility_inside"] < x["visibility_outside"]


def test_settings_without_one_bounce_are_refused():
    # the energy table's one-bounce columns compare with the path tracer's depth 3
    with pytest.raises(ValueError, match="bounces must include 1"):
        dataclasses.replace(e10.QUICK, bounces=(2, 3))
