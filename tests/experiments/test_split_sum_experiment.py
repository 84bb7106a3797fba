"""E11's plan and per-sphere scoring (experiments/paper/e11_split_sum.py), small and without OpenGL or Mitsuba:
the grid's layout against the scene file, the sphere masks against the geometry, the swaps against the
recipe they swap, the scores against hand-made images, and the progress count against a run with a
recording context."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest

import scenes
from experiments.measure import metrics
from experiments.paper import e11_split_sum as e11
from experiments.runs.rows import content_id
from scenes.model.render import Render

TINY = e11.Settings(height=24, object_size=16, probes=("uffizi", "ennis"), chain_size=8, frames=1, subpixels=1,
                    exact_samples=64, exact_lut=(16, 64), grid_spp=16)


def grid_scene(s: e11.Settings = TINY, **extra):
    return scenes.load(e11.GRID).with_overrides({**e11.grid_overrides(s, "uffizi"), **extra})


def test_the_grid_constants_name_each_spheres_material():
    """Sphere i is ROUGHNESS[i % 6] across and METALLIC[i // 6] down, as the scene file places it."""
    sc = grid_scene()
    assert len(sc.objects) == len(e11.ROUGHNESS) * len(e11.METALLIC)
    for i, obj in enumerate(sc.objects):
        j, k = divmod(i, len(e11.ROUGHNESS))
        assert obj.material.roughness == e11.ROUGHNESS[k] and obj.material.metallic == e11.METALLIC[j]
        assert obj.translate[0] == pytest.approx(2.4 * (k - 2.5)) and obj.translate[1] == pytest.approx(2.4 * (1 - j))


def test_each_mask_covers_its_own_sphere_only():
    """Masks are disjoint and non-empty; their centroids run left to right with roughness and top to bottom
    with metallic (image row 0 is the top), as the spheres' positions say."""
    sc = grid_scene(**{"camera.width": 96, "camera.height": 48})
    masks = e11.sphere_masks(sc)
    assert masks.shape == (18, 48, 96) and masks.any(axis=(1, 2)).all()
    assert masks.sum(axis=0).max() == 1
    ys, xs = np.mgrid[0:48, 0:96]
    cx = np.array([xs[m].mean() for m in masks]).reshape(3, 6)
    cy = np.array([ys[m].mean() for m in masks]).reshape(3, 6)
    assert (np.diff(cx, axis=1) > 10).all() and (np.diff(cy, axis=0) > 10).all()


def test_every_swap_is_a_valid_scene_that_differs_from_the_recipe():
    base = e11.recipe_overrides(TINY, e11.BASELINE, timed=False)
    ids = {content_id(grid_scene(**base))}
    for _, ov in e11.parts(TINY):
        ids.add(content_id(grid_scene(**{**base, **ov})))
    ids.add(content_id(grid_scene(**{**base, **e11.all_exact(TINY)})))
    assert len(ids) == len(e11.parts(TINY)) + 2


def test_scores_see_a_change_on_one_sphere_only():
    """Identical images score the PSNR cap everywhere; brightening one sphere lowers its score alone
    (negative control of the masks)."""
    sc = grid_scene(**{"camera.width": 96, "camera.height": 48})
    masks = e11.sphere_masks(sc)
    rng = np.random.default_rng(1)
    rgb = rng.uniform(0.1, 1.0, (48, 96, 3)).astype(np.float32)
    exact = Render(rgb, np.ones((48, 96), bool))
    same = e11.score_spheres(sc, exact, exact, masks)
    assert (same.psnr == metrics.PSNR_CAP).all() and np.allclose(same.flip, 0.0)
    changed = rgb.copy()
    changed[masks[7]] *= 1.5  # metallic 0.5, roughness 0.1
    scores = e11.score_spheres(sc, Render(changed, exact.mask), exact, masks)
    low = np.argwhere(scores.psnr < metrics.PSNR_CAP)
    assert low.tolist() == [[1, 1]]
    assert scores.energy[1, 1] == pytest.approx(1.5 * same.energy[1, 1], rel=1e-6)


def test_the_predicted_furnace_energy_falls_with_roughness_and_is_one_for_a_mirror():
    """The metal row's mean single-scattering albedo: ~1 for roughness 0 (the mirror loses nothing), 1 - ln 2
    at roughness 1 and normal incidence is the floor it cannot go below at mu near 1 (Kulla & Conty 2017)."""
    sc = grid_scene(**{"camera.width": 96, "camera.height": 48})
    e = e11.predicted_energy(sc, e11.sphere_masks(sc))
    assert e[0] == pytest.approx(1.0, abs=2e-3)
    assert (np.diff(e) < 0).all()
    assert 0.3 < e[-1] < 0.6


# --------------------------------------------------------------------------- a run with a recording context


@dataclass
class FakeRow:
    spec: str
    overrides: dict
    psnr: float = 30.0
    psnr_unbiased: float = 30.0
    flip: float = 0.05
    realtime_ms: dict = field(default_factory=lambda: {"total": 10.0, "precompute": 5.0})


class RecordingContext:
    """Stands in for experiments.paper.context.Context: records rows and progress steps, returns images
    that differ from the quadrature's by a known factor per recipe."""

    def __init__(self, out):
        self.out, self.steps, self.rows = out, 0, []
        (out / "figures").mkdir(parents=True)

    def base(self) -> dict:
        return {}

    def progress(self) -> None:
        self.steps += 1

    def row(self, spec, overrides, experiment):
        self.rows.append((spec, overrides))
        self.progress()
        return FakeRow(spec, overrides)

    def image_of(self, row):
        sc = scenes.load(row.spec).with_overrides(row.overrides)
        h, w = sc.camera.height, sc.camera.width
        gain = {"khronos": 1.0, "filament": 1.02, "threejs": 1.1, "babylon": 1.05}[
            row.overrides.get("realtime.split_sum.recipe", "khronos")]
        return sc, Render(np.full((h, w, 3), 0.5 * gain, np.float32), np.ones((h, w), bool))


def test_a_run_advances_the_progress_bar_as_often_as_count_steps_says(tmp_path, monkeypatch):
    def flat_quadrature(scene, subpixels):
        h, w = scene.camera.height, scene.camera.width
        return Render(np.full((h, w, 3), 0.5, np.float32), np.ones((h, w), bool)), 0.0

    monkeypatch.setattr(e11, "quadrature_of", flat_quadrature)
    ctx = RecordingContext(tmp_path)
    section = e11.run(ctx, TINY)
    assert ctx.steps == e11.count_steps(TINY)
    assert section.title == e11.TITLE and all((tmp_path / f).exists() for f in section.figures)
    # the recipe equal to the quadrature is found best; the others' order follows their known gains
    assert "khronos is closest to the exact integral" in section.markdown
    recipes = [ov["realtime.split_sum.recipe"] for spec, ov in ctx.rows if spec == e11.OBJECT]
    assert recipes == list(e11.RECIPES) * len(TINY.probes)
