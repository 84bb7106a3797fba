"""E10's plan and measurements (experiments/paper/e10_voxel_cone_tracing.py), small: the grid, the step count the paper
suite's progress bar uses, the memory comparison, and the thin-wall leak measured (GL)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import scenes
from experiments.measure.metrics import common_mask
from experiments.paper import e10_voxel_cone_tracing as e10
from groundtruth.pathtracer import reference
from scenes.environment.directions import rotation_xyz


@pytest.mark.parametrize("spec", [spec for _, spec in e10.SCENES])
def test_configs_are_direct_then_occlusion_and_interreflection_per_setting_then_the_ladder(spec):
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
    one, single_one = e10.memory("builtin:cornell-open", 64, 1, False)
    assert one == single_one  # one cascade is the plain 3D texture
    three, single = e10.memory("builtin:cornell-open", 64, 3, False)
    assert three == 3 * one and single > 20 * three  # 256^3 against three 64^3


def test_memory_counts_the_gloss_texture_where_interreflection_reads_a_glossy_surface():
    """Six RGBA16F faces, the RGBA16F column texture and six RGBA8 normals are 80 bytes a voxel; the gloss
    texture's six RGBA16F faces add 48 with interreflection on cornell-open (its Phong sphere), none on
    bowl-diffuse (no glossy surface) or with occlusion alone."""
    bare, _ = e10.memory("builtin:cornell-open", 32, 2, False)
    assert e10.memory("builtin:cornell-open", 32, 2, True)[0] == bare * (6 * 8 + 8 + 6 * 4 + 6 * 8) // 80
    assert e10.memory("builtin:bowl-diffuse", 32, 2, True) == e10.memory("builtin:bowl-diffuse", 32, 2, False)


@pytest.mark.gl
def test_thin_wall_leak_is_measured():
    (x,) = e10.thin_wall_leak((16,), offsets=2)
    assert x["outside"] > 0 and 0 <= x["inside"] < x["outside"]
    assert x["leak"] == pytest.approx(x["inside"] / x["outside"])
    assert min(x["leak"], x["leak_mean"]) <= x["leak_mean"] <= x["leak_max"] and x["placements"] == 2
    assert x["visibility_inside"] < x["visibility_outside"]


@pytest.mark.parametrize("rotate_deg", [(0.0, 0.0, 0.0), (20.0, 25.0, 0.0), (90.0, 0.0, 0.0)])
def test_turned_thin_wall_probes_stay_on_the_turned_floor_inside_and_outside_the_box(rotate_deg):
    # the box's walls stand on the ground y = 0 at x, z = +-0.5 before turning; turned back by the rotation's
    # transpose, every probe must be on that ground (y = 0), the inside ones within the walls, the outside
    # ones beyond them, and the normal the ground's up
    objects, inside, outside, up = e10.thin_wall_probes(scenes.load("builtin:thin-wall"), rotate_deg)
    r = rotation_xyz(rotate_deg)
    ground = objects[0].mesh
    assert np.allclose((ground.positions.astype(np.float64) @ r)[:, 1], 0.0, atol=1e-6)
    back_in, back_out = inside @ r, outside @ r
    assert np.allclose(back_in[:, 1], 0.0, atol=1e-12) and np.allclose(back_out[:, 1], 0.0, atol=1e-12)
    assert np.abs(back_in[:, [0, 2]]).max() < 0.5 < np.abs(back_out[:, [0, 2]]).max(axis=1).min()
    assert np.allclose(up @ r, [0.0, 1.0, 0.0])
    assert np.allclose(ground.normals @ r, [0.0, 1.0, 0.0], atol=1e-6)


def test_turned_thin_wall_probes_are_not_the_unturned_ones():
    # negative control of the test above: the turn moves the probes off the unturned ground
    _, inside, _, up = e10.thin_wall_probes(scenes.load("builtin:thin-wall"), (20.0, 25.0, 0.0))
    assert np.abs(inside[:, 1]).max() > 0.05 and abs(up[1]) < 0.95


@pytest.fixture(scope="module")
def unturned_16() -> dict:
    (row,) = e10.thin_wall_leak((16,))
    return row


@pytest.mark.gl
def test_quarter_turn_about_the_ground_normal_keeps_the_leak(unturned_16):
    # a quarter turn about y maps the box, the ground and both probe sets onto themselves (and the grid, centred
    # on bounds that do not change): the leak must not move beyond the voxelisation of the ground's triangles
    still = unturned_16
    (turned,) = e10.thin_wall_leak((16,), rotate_deg=(0.0, 90.0, 0.0))
    assert turned["leak"] == pytest.approx(still["leak"], rel=0.05, abs=1e-4)
    assert turned["outside"] == pytest.approx(still["outside"], rel=0.02)


@pytest.mark.gl
def test_an_oblique_turn_voxelises_the_turned_scene(unturned_16):
    # the grid is sized to the voxelised objects' bounds: turned, the ground (corners x, z = +-2) and the box
    # (x, z = +-0.5, height 1) span more along the largest axis, so the voxel grows by exactly that span's
    # ratio (negative control: the unturned objects voxelised with turned probes would keep the unturned voxel)
    ground = [[x, 0.0, z] for x in (-2.0, 2.0) for z in (-2.0, 2.0)]
    box = [[x, y, z] for x in (-0.5, 0.5) for y in (0.0, 1.0) for z in (-0.5, 0.5)]
    corners = np.array(ground + box)
    turned_span = np.ptp(corners @ rotation_xyz((20.0, 25.0, 0.0)).T, axis=0).max()
    (turned,) = e10.thin_wall_leak((16,), rotate_deg=(20.0, 25.0, 0.0))
    assert turned["voxel"] / unturned_16["voxel"] == pytest.approx(turned_span / 4.0, rel=1e-3)


@pytest.mark.gl
def test_oblique_walls_leak_under_one_percent_at_64():
    # the box turned 20 degrees about x and 25 about y, its walls oblique to every axis of the grid: no light
    # reaches the ground inside in the path tracer, so what the cones find there over outside must stay under
    # E10's 1 % target at 64^3 (the grid's own placement; the worst of E10's shifted placements is not under
    # test), as for walls along the axes. Control: a texel showing a cone a two-sided wall's dark side adding
    # the light behind it (tests/mutants/shader_mutants.py, run with --tests tests/experiments) lets 1.9 %
    # through here; a roofless box reading the sky is the measure's own control in test_vct_gpu
    (row,) = e10.thin_wall_leak((64,), rotate_deg=(20.0, 25.0, 0.0))
    assert row["leak"] < 0.01, row


def test_settings_without_one_bounce_are_refused():
    # the energy table's one-bounce columns compare with the path tracer's depth 3
    with pytest.raises(ValueError, match="bounces must include 1"):
        dataclasses.replace(e10.QUICK, bounces=(2, 3))


@pytest.mark.gl
@pytest.mark.mitsuba
def test_area_render_integrates_the_silhouette_as_the_path_tracer_does():
    """A diffuse sphere at 48 x 48 against the path tracer (256 spp): rendered 4 times larger and box-reduced, the
    real-time image's silhouette pixels (covered in either image, outside the eroded mask) are as close to the
    path tracer's as its inner pixels are (within 1.5 times their mean relative error: SH9's own error and the
    reference's noise), and its mask is the path tracer's but for a few pixels. Control: point-sampled at the
    pixels' centres (area_render with 1), the silhouette pixels are off by more than 2.5 times as much."""
    scene = scenes.load("builtin:sphere-diffuse").with_overrides(
        {"camera.width": 48, "camera.height": 48, "realtime.timing_frames": 1, "realtime.warmup_frames": 0,
         "reference.spp": 256})
    theirs = reference.render(scene)
    inner = common_mask(theirs.mask, theirs.mask)

    def errors(ours) -> tuple[float, float]:
        assert ours.rgb.shape == theirs.rgb.shape
        edge = (ours.mask | theirs.mask) & ~inner
        return tuple(float(np.abs(ours.rgb[m] - theirs.rgb[m]).mean() / theirs.rgb[m].mean()) for m in (edge, inner))

    integrated = e10.area_render(scene, 4)
    edge, inside = errors(integrated)
    assert edge < 1.5 * inside
    assert (integrated.mask != theirs.mask).sum() <= 0.02 * theirs.mask.sum()
    edge_point, inside_point = errors(e10.area_render(scene, 1))
    assert edge_point > 2.5 * inside_point
