"""groundtruth.exact.reflectance (the paper's reflectance in numpy) against values worked out by hand.

The quadrature normalises its kernels by their discrete sums, so a wrong lobe normalisation cancels out
there: these checks hold the formulas themselves (docs/contract.md section 3):
lobe = (N + 1) / (2 pi) max(r.l, 0)^N, Schlick's F, the mirror direction 2 (n.v) n - v.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from groundtruth.exact import reflectance
from scenes.model.scene import Material


@pytest.mark.parametrize(("one_minus_cos", "exponent", "value"), [
    (0.0, 100.0, 101 / (2 * math.pi)),             # the peak: (N + 1) / (2 pi) = 16.0746...
    (0.5, 2.0, 3 / (2 * math.pi) * 0.25),          # cos = 1/2: 3 / (2 pi) * 1/4 = 0.119366...
    (0.1, 10.0, 11 / (2 * math.pi) * 0.9**10),     # 11 / (2 pi) * 0.348678... = 0.610417...
    (1.0, 5.0, 0.0),                               # r.l = 0: nothing
    (1.5, 5.0, 0.0),                               # behind the lobe: nothing
    (0.5, 0.0, 1 / (2 * math.pi)),                 # N = 0: the uniform hemisphere about r, 1 / (2 pi)
    (1.0, 0.0, 1 / (2 * math.pi)),                 # ... including its rim (0^0 = 1)
    (1.2, 0.0, 0.0),                               # ... and nothing behind it
])
def test_phong_lobe_by_hand(one_minus_cos, exponent, value):
    assert reflectance.phong_lobe(np.array(one_minus_cos), exponent) == pytest.approx(value, rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("exponent", [0.0, 1.0, 20.0, 500.0])
def test_phong_lobe_integrates_to_one(exponent):
    """Over the sphere, in t = 1 - cos about r: int_0^1 lobe(t) 2 pi dt = 1 (midpoint rule, 2e5 steps:
    error below 1e-6 even for N = 500, whose lobe spans t < ~0.02)."""
    n = 200_000
    t = (np.arange(n) + 0.5) / n
    assert np.sum(reflectance.phong_lobe(t, exponent)) * 2 * math.pi / n == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize(("kind", "n_dot_v", "wd", "wg"), [
    ("diffuse", [1.0, 0.3, 0.0], [1.0, 1.0, 1.0], [0.0, 0.0, 0.0]),
    ("phong", [1.0, 0.3, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]),
    # blend, f0 = 0.04: F(1) = 0.04; F(0.3) = 0.04 + 0.96 * 0.7^5 = 0.201347; F(0) = 1
    ("blend", [1.0, 0.3, 0.0], [0.96, 1 - 0.20134720, 0.0], [0.04, 0.20134720, 1.0]),
])
def test_lobe_weights_by_hand(kind, n_dot_v, wd, wg):
    got_d, got_g = reflectance.lobe_weights(Material(kind, f0=0.04), np.array(n_dot_v))
    assert got_d.shape == got_g.shape == (3,)
    np.testing.assert_allclose(got_d, wd, atol=1e-8)
    np.testing.assert_allclose(got_g, wg, atol=1e-8)


def test_reflect_on_arrays_of_any_shape():
    # v = (0, 1, 1)/sqrt2 about n = +Z: (0, -1, 1)/sqrt2; v = n: itself; in a (2, 2, 3) array, per vector
    s = 1 / math.sqrt(2)
    v = np.array([[[0.0, s, s], [0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0], [s, 0.0, s]]])
    n = np.broadcast_to([0.0, 0.0, 1.0], v.shape)
    expected = np.array([[[0.0, -s, s], [0.0, 0.0, 1.0]], [[-1.0, 0.0, 0.0], [-s, 0.0, s]]])
    np.testing.assert_allclose(reflectance.reflect(v, n), expected, atol=1e-15)
