"""White furnace: a unit sphere in a constant environment of radiance 1.

- diffuse kd = 1: every covered pixel is 1 (energy conservation of the plugin, the emitter and
  the integrator together);
- phong ks = 1: 1 minus the part of the lobe below the horizon, computed here analytically:
  in the lobe's frame (alpha, phi) about r, a direction is above the horizon of n when
  cos(alpha) cos(t) + sin(alpha) sin(t) cos(phi) > 0, t = angle(n, r); the fraction of phi for which
  that holds is acos(-cot(alpha) cot(t)) / pi, and the lobe's CDF in u = cos^(N+1)(alpha) is uniform.

Tolerance (sigma: one render's pixel noise, measured from a second seed): the mean within
5 sigma / sqrt(pixels) + 1e-3, each of five bands of n.v within 5 sigma / sqrt(band pixels)
+ 3e-3 (the mesh's facets and the pixel footprint), 99% of pixels within 4 sigma + 1e-3.
"""

from __future__ import annotations

import numpy as np
import pytest

import groundtruth
from experiments.measure import metrics
from groundtruth.exact import raycast
from tests.groundtruth.common import furnace_scene, horizon_fraction

pytestmark = pytest.mark.mitsuba


def expected_phong(scene) -> tuple[np.ndarray, np.ndarray]:
    """(per-pixel expected radiance, per-pixel n.v): the horizon fraction over 4 x 4 sub-pixel rays."""
    hits = raycast.cast(scene, subpixels=4)
    cos_nv = (hits.normal * -hits.direction).sum(-1)
    # r is the mirror of v about n, so angle(n, r) = angle(n, v)
    frac = np.where(hits.hit, horizon_fraction(cos_nv, scene.objects[0].material.exponent), 1.0)
    return frac.mean(axis=2), cos_nv.mean(axis=2)


def check_furnace(r1, r2, expected: np.ndarray, cos_nv: np.ndarray) -> None:
    """Unbiased within noise overall and per band of n.v; 99% of pixels within 4 sigma (the rest is
    the heavy tail of light-sampled glossy paths)."""
    mask = metrics.common_mask(r1.mask, r2.mask, erode=2)
    sigma = np.std((r1.rgb - r2.rgb)[mask]) / np.sqrt(2)
    err = r1.rgb[mask] - expected[mask][:, None]
    assert abs(err.mean()) < 5 * sigma / np.sqrt(err.size) + 1e-3, (err.mean(), sigma)
    assert np.quantile(np.abs(err), 0.99) < 4 * sigma + 1e-3, (np.quantile(np.abs(err), 0.99), sigma)
    # five bands of n.v holding equally many pixels (a band of a dozen pixels at the silhouette
    # would see the skewed noise of light-sampled glossy paths, not a bias)
    c = cos_nv[mask]
    edges = np.quantile(c, np.linspace(0, 1, 6))
    band = np.clip(np.searchsorted(edges, c, side="right") - 1, 0, 4)
    for b in range(5):
        e = err[band == b]
        assert abs(e.mean()) < 5 * sigma / np.sqrt(e.size) + 3e-3, (edges[b], e.mean(), sigma)


def test_diffuse_white_furnace_is_one(tmp_path, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    scene = furnace_scene(tmp_path, '{ type = "diffuse", kd = [1.0, 1.0, 1.0] }')
    r1, r2 = groundtruth.render_pair(scene)
    check_furnace(r1, r2, np.ones(r1.rgb.shape[:2]), expected_phong(scene)[1])


@pytest.mark.parametrize("exponent", [1.0, 10.0, 1000.0])
def test_phong_white_furnace_loses_only_the_horizon(tmp_path, monkeypatch, exponent):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    material = f'{{ type = "phong", ks = [1.0, 1.0, 1.0], exponent = {exponent} }}'
    scene = furnace_scene(tmp_path, material, spp=256)
    r1, r2 = groundtruth.render_pair(scene)
    expected, cos_nv = expected_phong(scene)
    check_furnace(r1, r2, expected, cos_nv)
    if exponent == 1.0:  # the loss is real: near the silhouette well under 1
        assert expected[r1.mask].min() < 0.8


def test_horizon_fraction_limits():
    """The analytic helper itself: no loss at normal incidence for a narrow lobe; half at grazing."""
    assert horizon_fraction(np.array(1.0), 1000.0) == pytest.approx(1.0, abs=1e-9)
    assert horizon_fraction(np.array(0.0), 1e5) == pytest.approx(0.5, abs=1e-3)
    # N = 0 about n itself: the uniform hemisphere lies entirely above the horizon
    assert horizon_fraction(np.array(1.0), 0.0) == pytest.approx(1.0, abs=1e-6)
