"""The Mitsuba reference against the independent quadrature (numpy raycast + cell-grid sums).

Agreement to within the reference's own noise checks the plugin, the emitter's orientation and
rotation, the camera and the mesh hand-over at once: a flipped axis or a wrong lobe normalisation
costs many dB. The quadrature itself is checked analytically in test_furnace.py (horizon loss)
and here on a constant environment.
"""

from __future__ import annotations

import numpy as np
import pytest

import groundtruth
from experiments.measure import metrics
from groundtruth.exact import quadrature, raycast
from tests.groundtruth.common import furnace_scene, horizon_fraction, masked_psnr, small

SIZE = 48


@pytest.mark.mitsuba
@pytest.mark.parametrize(("name", "overrides"), [
    ("builtin:sphere-diffuse", {}),
    ("builtin:sphere-blend", {}),
    ("builtin:sphere-blend", {"environment.rotation_deg": 70.0, "camera.origin": [2.0, 1.5, 3.0]}),
    ("builtin:sphere-phong", {"objects.0.material.exponent": 1000.0}),
    ("builtin:sphere-phong", {"objects.0.material.exponent": 1e6}),  # a mirror: the quadrature's lobe frame
])
def test_reference_matches_quadrature_within_its_noise(tmp_path, monkeypatch, name, overrides):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    scene = small(name, size=SIZE, spp=256, **overrides)
    r1, r2 = groundtruth.render_pair(scene)
    q = quadrature.render(scene)
    mask = metrics.common_mask(r1.mask, r2.mask)
    floor = metrics.noise_floor_psnr(metrics.display(scene, r1.rgb), metrics.display(scene, r2.rgb), mask)
    score = masked_psnr(scene, q, r1)
    assert score >= floor - 1.0, (score, floor)
    # the masks come from different code (Mitsuba coverage pass, numpy raycast): same silhouette
    assert (q.mask != r1.mask).sum() <= 0.03 * r1.mask.sum()


@pytest.mark.mitsuba
def test_noise_floor_is_the_psnr_the_truth_reaches(tmp_path, monkeypatch):
    """The quadrature is noise-free, so its PSNR against a reference is what the noise floor claims."""
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    scene = small("builtin:sphere-diffuse", size=SIZE, spp=64)
    r1, r2 = groundtruth.render_pair(scene)
    q = quadrature.render(scene)
    mask = metrics.common_mask(r1.mask, r2.mask) & q.mask
    d = lambda x: metrics.display(scene, x.rgb)  # noqa: E731
    floor = metrics.noise_floor_psnr(d(r1), d(r2), mask)
    assert metrics.psnr(d(q), d(r1), mask) == pytest.approx(floor, abs=0.6)


@pytest.mark.parametrize("material", ['{ type = "diffuse", kd = [0.5, 0.6, 0.7] }',
                                      '{ type = "phong", ks = [1.0, 1.0, 1.0], exponent = 0.0 }',
                                      '{ type = "blend", kd = [0.5, 0.5, 0.5], ks = [1.0, 1.0, 1.0], '
                                      'exponent = 1e6, f0 = 0.04 }'])
def test_quadrature_constant_environment(tmp_path, material):
    """Radiance 1 everywhere: diffuse gives kd exactly; a lobe gives the part of it above the horizon, and
    blend (1 - F) kd + F ks frac, with frac the analytic horizon fraction of the lobe (common.py) and
    Schlick's F written out here, averaged over the same 4 x 4 sub-pixel rays. Tolerance 1e-3: the
    quadrature cuts the lobe at the horizon cell by cell (measured: within 7e-4 of the analytic fraction
    for N = 0, 3e-8 for N = 1e6); a lobe without its horizon cut (frac = 1) is off by 0.39 near the
    silhouette."""
    scene = furnace_scene(tmp_path, material, size=16, resolution=48)
    q = quadrature.render(scene)
    assert np.isfinite(q.rgb).all()
    hits = raycast.cast(scene, subpixels=4)
    inside, outside = hits.hit.all(axis=2), ~hits.hit.any(axis=2)  # fully covered / not at all
    m = scene.objects[0].material
    if m.type == "diffuse":
        np.testing.assert_allclose(q.rgb[inside], np.broadcast_to([0.5, 0.6, 0.7], q.rgb[inside].shape), atol=1e-9)
    else:
        cos_nv = np.clip((hits.normal * -hits.direction).sum(-1), -1.0, 1.0)  # angle(n, r) = angle(n, v)
        frac = horizon_fraction(cos_nv, m.exponent)
        F = 1.0 if m.type == "phong" else m.f0 + (1 - m.f0) * (1 - np.clip(cos_nv, 0.0, 1.0)) ** 5
        kd = m.kd[0] if m.type == "blend" else 0.0  # grey kd, ks = 1
        expected = ((1 - F) * kd + F * frac).mean(axis=2)
        np.testing.assert_allclose(q.rgb[inside], np.repeat(expected[inside][:, None], 3, axis=1), atol=1e-3)
        # what is checked is there to be seen: the horizon loss of a wide lobe, F rising to the silhouette
        assert np.ptp(expected[inside]) > 0.05
    np.testing.assert_allclose(q.rgb[outside], 1.0, atol=1e-6)  # the background
