"""Precomputed radiance transfer in the shading pass (realtime/techniques/prt/prt.py) against independent expectations.

- A convex object's transfer is its unshadowed transfer A_l Y_k(n), so PRT shading of a sphere equals
  SH irradiance of the same order (`diffuse = "sh"`, the paper's path for order 2) to float precision,
  for every order, shadowed or not.
- A constant environment gives kd for the unshadowed transfer (band 0 only: E = pi).
- Shadowing only takes light away and bounces only add it back (the plane of sphere-on-plane: darker
  under the sphere with occlusion, brighter again with a bounce, never above the unshadowed image
  plus the sphere's whole albedo times its irradiance).
"""

from __future__ import annotations

import numpy as np
import pytest

import realtime
from realtime.engine import technique

from .test_render import small

pytestmark = pytest.mark.gl


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))


@pytest.mark.parametrize("order", [2, 3, 4])
@pytest.mark.parametrize("occlusion", ["none", "prt"])
def test_prt_of_a_convex_sphere_is_sh_irradiance_of_the_same_order(order, occlusion):
    base = {"environment.rotation_deg": 40.0, "objects.0.material.kd": [0.8, 0.5, 0.2]}
    sh = realtime.render(small("builtin:sphere-diffuse", **base, **{"realtime.sh_order": order}))
    prt_ov = {"realtime.diffuse": "prt", "realtime.prt.order": order, "realtime.occlusion": occlusion}
    if occlusion == "prt":
        prt_ov["realtime.prt.rays"] = 16
    prt = realtime.render(small("builtin:sphere-diffuse", **base, **prt_ov))
    assert (sh.mask == prt.mask).all()
    # per-vertex E interpolated (PRT) against per-pixel E of the interpolated normal (SH): equal at the
    # vertices; between them the difference is the curvature of E over one triangle (96 bands)
    np.testing.assert_allclose(prt.rgb[prt.mask], sh.rgb[sh.mask], rtol=2e-3, atol=2e-4)


def test_prt_at_the_vertices_is_sh_irradiance_to_float_precision():
    """The transfer dotted with the environment's SH (the vertex shader's sum) against numpy SH irradiance."""
    import scenes
    from realtime.engine.sh import irradiance_from_sh, project_equirect
    from realtime.techniques.prt.prt import transfer_objects
    from realtime.techniques.prt.prt_transfer import transfer

    scene = scenes.load("builtin:sphere-diffuse").with_overrides({"environment.rotation_deg": 40.0})
    for order in (2, 4):
        (t,) = transfer(transfer_objects(scene), order, 16, 0, shadowed=True)
        coeffs = project_equirect(scene.environment.radiance(), 40.0, order=order)  # (n, 3)
        e_prt = np.einsum("kc,vkc->vc", coeffs, t.astype(np.float64))
        if order == 2:
            want = irradiance_from_sh(coeffs, scene.objects[0].mesh.normals.astype(np.float64))
        else:
            from realtime.engine.sh_orders import irradiance_weights
            from scenes.environment.shbasis import sh_basis

            want = sh_basis(scene.objects[0].mesh.normals.astype(np.float64), order) @ irradiance_weights(coeffs)
        np.testing.assert_allclose(e_prt, want, rtol=1e-5, atol=1e-6 * np.abs(want).max())


def test_constant_environment_unshadowed_prt_shows_kd():
    scene = small("builtin:sphere-diffuse", **{"environment.map": "builtin:constant", "realtime.diffuse": "prt",
                                                "objects.0.material.kd": [0.8, 0.5, 0.2]})
    r = realtime.render(scene)
    np.testing.assert_allclose(r.rgb[r.mask], np.broadcast_to([0.8, 0.5, 0.2], r.rgb[r.mask].shape), atol=1e-3)


def test_shadows_darken_and_bounces_brighten_the_plane_under_the_sphere():
    # a constant environment of radiance 1: only band 0 lights (E = L00 T00), so the per-vertex order
    # holds exactly: occlusion takes light away (T00 drops by the occluded cosine fraction), a bounce
    # adds kd times the occluder's own transfer back (>= 0), and since every surface's radiance is at
    # most kd <= 1 times the sky's, never more than the sky it blocked (MC noise: 2%)
    base = {"camera.width": 64, "camera.height": 64, "objects.0.resolution": 32, "objects.1.resolution": 32,
            "environment.map": "builtin:constant", "realtime.diffuse": "prt", "realtime.prt.order": 3}
    plain = realtime.render(small("builtin:sphere-on-plane", **base))
    shadowed = realtime.render(small("builtin:sphere-on-plane", **base, **{"realtime.occlusion": "prt",
                                                                          "realtime.prt.rays": 128}))
    bounced = realtime.render(small("builtin:sphere-on-plane", **base, **{
        "realtime.occlusion": "prt", "realtime.interreflection": "prt", "realtime.prt.rays": 128,
        "realtime.prt.bounces": 1}))
    m = plain.mask & shadowed.mask & bounced.mask
    lum = [x.rgb[m].mean(axis=1) for x in (plain, shadowed, bounced)]
    assert lum[1].mean() < 0.95 * lum[0].mean()  # the contact shadow and the sphere's occluded underside
    assert (lum[1] <= lum[0] * 1.02).all()
    assert lum[2].mean() > lum[1].mean()  # light bounced off the plane and the sphere
    assert (lum[2] >= lum[1] - 1e-5).all()  # a bounce only adds
    assert (lum[2] <= lum[0] * 1.02).all()
    assert technique.unsimulated_effects(small("builtin:sphere-on-plane", **base, **{
        "realtime.occlusion": "prt", "realtime.interreflection": "prt", "realtime.prt.bounces": 1})) == []


SPHERE_KD, PLANE_KD = (0.9, 0.5, 0.2), (0.4, 0.6, 0.8)


def test_the_bounce_in_the_image_is_tinted_by_both_albedos_per_channel():
    """Per pixel and channel, what one bounce adds to the image (bounced minus shadowed render, the same
    rays) is a channel-free quantity times kd_sphere,c x kd_plane,c: under a white constant environment
    the shadowed transfer is grey; the plane's rays only meet the sphere (gathered through kd_sphere) and
    the sphere's only the plane (through kd_plane); the pixel multiplies by its own kd. The expectation is
    the product of the scene's albedos; with these albedos the transfer's channels read in another order
    (in the upload or the vertex shader), or one channel read for all, gives another tint on the sphere
    or on the plane."""
    base = {"camera.width": 48, "camera.height": 48, "objects.0.resolution": 24, "objects.1.resolution": 16,
            "environment.map": "builtin:constant", "realtime.diffuse": "prt", "realtime.prt.order": 2,
            "realtime.occlusion": "prt", "realtime.prt.rays": 64,
            "objects.0.material.kd": list(SPHERE_KD), "objects.1.material.kd": list(PLANE_KD)}
    with pytest.warns(technique.UnsimulatedEffectWarning):
        shadowed = realtime.render(small("builtin:sphere-on-plane", **base))
    bounced = realtime.render(small("builtin:sphere-on-plane", **base, **{"realtime.interreflection": "prt",
                                                                          "realtime.prt.bounces": 1}))
    m = shadowed.mask & bounced.mask
    added = (bounced.rgb[m] - shadowed.rgb[m]).astype(np.float64)  # (P, 3)
    tint = np.multiply(SPHERE_KD, PLANE_KD)
    # float32 radiance of up to kd_max E / pi ~ 1 and its interpolation: 1e-5 absolute on the channel-free part
    strong = added[:, 0] / tint[0] > 2e-3
    assert strong.sum() > 50  # the contact region of the plane and the sphere's underside
    grey = added[strong] / tint
    np.testing.assert_allclose(grey[:, 1], grey[:, 0], rtol=2e-3, atol=1e-5)
    np.testing.assert_allclose(grey[:, 2], grey[:, 0], rtol=2e-3, atol=1e-5)
    # negative control: tinted by one albedo only (the transfer's channels mixed up) is far off
    for wrong in (np.asarray(SPHERE_KD), np.asarray(PLANE_KD), tint[::-1]):
        other = added[strong] / wrong
        assert np.abs(other[:, 2] / other[:, 0] - 1).max() > 0.1
