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
