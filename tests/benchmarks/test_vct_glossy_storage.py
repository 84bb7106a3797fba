"""The numpy model behind benchmarks/vct_glossy_storage.py, against expectations found independently: the torus's
normal is its distance function's gradient, sphere tracing lands on the analytic torus where a ray's hit is
known, the Phong lobe's samples have the lobe's mean cosine, and the six-face read reproduces a face's value
where the cone looks along an axis at a surface facing it, blends a constant to itself, and reads nothing
from a surface facing away."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import scenes

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("vct_glossy_storage", ROOT / "benchmarks" / "vct_glossy_storage.py")
model = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(model)


def test_torus_normal_is_the_distance_gradient():
    rng = np.random.default_rng(0)
    p = rng.uniform(-1.2, 1.2, (200, 3))
    p = p[np.abs(model.torus_distance(p)) < 0.2]
    eps = 1e-6
    grad = np.stack([(model.torus_distance(p + eps * e) - model.torus_distance(p - eps * e)) / (2 * eps)
                     for e in np.eye(3)], -1)
    assert np.allclose(model.torus_normal(p), grad, atol=1e-5)


def test_a_ray_down_the_tube_lands_on_its_top():
    """A ray straight down at x = ring radius meets the tube's top at y = tube radius; one down the hole's
    axis misses (control)."""
    hit, q = model.march(np.array([[model.RING, 3.0, 0.0], [0.0, 3.0, 0.0]]), np.array([[0.0, -1.0, 0.0]] * 2))
    assert hit[0] and not hit[1]
    assert q[0] == pytest.approx([model.RING, model.TUBE, 0.0], abs=1e-4)


@pytest.mark.parametrize("above_top", [-1e-5, 2e-5])
def test_rays_grazing_the_tube_are_resolved(above_top):
    """A level ray passing the tube's top (y = tube radius) 1e-5 below it meets the outer side where the
    circle of the tube's cross-section puts it; 2e-5 above, it passes. Either takes more than 200 steps
    (control: a march held to 200 steps reports the ray unresolved instead of calling it a miss)."""
    y = model.TUBE + above_top
    origin, direction = np.array([[-3.0, y, 0.0]]), np.array([[1.0, 0.0, 0.0]])
    hit, q = model.march(origin, direction)
    assert bool(hit[0]) == (above_top < 0)
    if above_top < 0:
        assert abs(model.torus_distance(q[0])) < 1e-5
        # sphere tracing stops within 1e-5 of the surface, about 1e-3 short along so grazing a ray; the tube's
        # top, 2.4e-3 further on, is out of the band
        hit_x = -model.RING - np.sqrt(model.TUBE ** 2 - y ** 2)
        assert hit_x - 1.5e-3 <= q[0, 0] <= hit_x + 1e-6
    with pytest.raises(RuntimeError, match="unresolved"):
        model.march(origin, direction, max_steps=200)


def test_lobe_samples_have_the_lobes_mean_cosine():
    """The normalised Phong lobe's mean cos a is (N + 1) / (N + 2)."""
    axis = np.array([[0.3, 0.5, -0.81]])
    axis /= np.linalg.norm(axis)
    w = model.lobe_directions(axis, 200_000, np.random.default_rng(2))[0]
    n = model.EXPONENT
    assert (w @ axis[0]).mean() == pytest.approx((n + 1) / (n + 2), abs=2e-4)
    assert np.allclose(np.linalg.norm(w, axis=-1), 1.0)


def test_six_face_read_along_an_axis_is_that_face():
    """A cone along -y reads a +y-facing surface's +y face alone (the face's value is labelled by its mirror
    direction, here +y itself); a constant blends to itself from any direction; a surface facing away from
    every face the cone reads carries nothing."""
    n = np.array([[0.0, 1.0, 0.0]])
    value, carried = model.face_blend(np.array([[0.0, -1.0, 0.0]]), n, lambda r: r[:, 1:2] + 10.0 * r[:, 0:1])
    assert carried[0] and value[0, 0] == pytest.approx(1.0)
    rng = np.random.default_rng(4)
    w = rng.normal(size=(50, 3))
    w /= np.linalg.norm(w, axis=-1, keepdims=True)
    tilted = np.tile(np.array([[0.3, 0.8, 0.52]]) / np.linalg.norm([0.3, 0.8, 0.52]), (50, 1))
    value, carried = model.face_blend(w, tilted, lambda r: np.full((len(r), 1), 0.7))
    assert carried.sum() > 10 and np.allclose(value[carried], 0.7)
    _, carried = model.face_blend(np.array([[0.0, 1.0, 0.0]]), n, lambda r: np.ones((len(r), 1)))
    assert not carried[0]


@pytest.mark.mitsuba
def test_model_direct_light_is_the_path_tracers():
    """The model's direct light (its camera, pixel integration, probe orientation and lobe) against the path
    tracer's max_depth 2 at the same 32 x 32 pixels, the environment showing past the torus's edge in both: the
    means within 1 %, the per-pixel mean absolute error (both sides' sampling noise) under 8 % of the mean.
    Controls: the model's image mirrored left-right or upside down is far off (over 25 %), so the comparison
    can tell the camera's axes apart."""
    scene = scenes.load("builtin:torus-phong")
    model_images = model.one_bounce_images(scene, 32, 4, 4, 32)
    path_direct, _, path_mask = model.path_traced_one_bounce(scene, 32, 256)
    ours, theirs = model_images["direct"].mean(-1), path_direct.mean(-1)

    def relative_error(image, mask):
        return np.abs(image[mask] - theirs[mask]).mean() / theirs[mask].mean()

    mask = model_images["covered"] & path_mask
    assert ours[mask].mean() == pytest.approx(theirs[mask].mean(), rel=0.01)
    assert relative_error(ours, mask) < 0.08
    assert relative_error(ours[:, ::-1], mask & mask[:, ::-1]) > 0.25
    assert relative_error(ours[::-1], mask & mask[::-1]) > 0.25


def test_cap_samples_have_the_caps_mean_cosine():
    """Directions uniform over a cap of half-angle a have mean cos (1 + cos a) / 2 about its axis, all inside it."""
    axis = np.array([[0.0, 0.6, 0.8]])
    half = np.radians(33.56)
    w = model.cap_directions(axis, half, 200_000, np.random.default_rng(3))[0]
    assert (w @ axis[0]).mean() == pytest.approx((1 + np.cos(half)) / 2, abs=2e-4)
    assert (w @ axis[0]).min() >= np.cos(half) - 1e-12


def test_the_nearest_diffuse_cones_visibility():
    """The outer equator (1, 0, 0), normal +x: every direction with d_x > 0 leaves the ring's radius for good, so
    the cone about the normal is wholly open. The inner equator (0.4, 0, 0), normal -x: the cone about the
    normal looks across the hole, its axis meeting the far side of the tube, its rim (33.6 degrees up) clearing
    the far tube's top (0.8 tan 33.6 deg = 0.53 > 0.3): partly blocked. Control: the inner point's cone nearest
    +y (a ring cone, 43.3 degrees from +y) sees more sky than the one across the hole."""
    p = np.array([[model.RING + model.TUBE, 0.0, 0.0], [model.RING - model.TUBE, 0.0, 0.0],
                  [model.RING - model.TUBE, 0.0, 0.0]])
    n = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    towards = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    v = model.nearest_diffuse_cone_visibility(p, n, towards, 512)
    assert v[0] == 1.0
    assert 0.05 < v[1] < 0.95
    assert v[2] > v[1] + 0.05
