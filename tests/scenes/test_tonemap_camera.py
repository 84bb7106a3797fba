"""Tone mapping against hand-computed values; the camera's axes, rows and vertical fov."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.environment import environments
from scenes.model import tonemap
from scenes.model.camera import Camera


def test_reinhard_hand_values():
    # key 0.18, L_avg 1, white 4: L = 1 -> L_m = 0.18 -> 0.18 (1 + 0.18/16) / 1.18 = 0.15425847...
    assert tonemap.reinhard(1.0, 0.18, 4.0, 0.0, 1.0) == pytest.approx(0.18 * 1.01125 / 1.18, rel=1e-12)
    # at the white point the output is exactly 1; beyond it, clamped to 1
    assert tonemap.reinhard(4.0 / 0.18, 0.18, 4.0, 0.0, 1.0) == pytest.approx(1.0, rel=1e-12)
    assert tonemap.reinhard(1e3, 0.18, 4.0, 0.0, 1.0) == 1.0
    # one stop of exposure doubles L_m: L = 1, exposure 1 -> L_m = 0.36 -> 0.36 (1 + 0.36/16) / 1.36
    assert tonemap.reinhard(1.0, 0.18, 4.0, 1.0, 1.0) == pytest.approx(0.36 * 1.0225 / 1.36, rel=1e-12)


def test_reinhard_adaptation_and_edges_by_hand():
    # L_avg = 0.5 doubles L_m: L = 1 -> L_m = 0.36 -> 0.36 (1 + 0.36/16) / 1.36 (as one stop of exposure)
    assert tonemap.reinhard(1.0, 0.18, 4.0, 0.0, 0.5) == pytest.approx(0.36 * 1.0225 / 1.36, rel=1e-12)
    # L_avg = 4, exposure -1: L_m = 0.18 / 4 / 2 * 8 = 0.18 -> 0.18 (1 + 0.18/16) / 1.18
    assert tonemap.reinhard(8.0, 0.18, 4.0, -1.0, 4.0) == pytest.approx(0.18 * 1.01125 / 1.18, rel=1e-12)
    # a black environment (L_avg -> 0) is floored at 1e-30, not at 1: L = 1e-20 -> L_m = 1.8e9 >= white -> 1
    assert tonemap.reinhard(1e-20, 0.18, 4.0, 0.0, 0.0) == 1.0
    # negative, -Inf and NaN radiance show black, +Inf white
    np.testing.assert_array_equal(tonemap.reinhard(np.array([-1.0, -np.inf, np.nan, np.inf]), 0.18, 4.0, 0.0, 1.0),
                                  [0.0, 0.0, 0.0, 1.0])


def test_srgb_clamps_and_quantises():
    # display-linear values outside [0, 1] are clamped before encoding
    np.testing.assert_allclose(tonemap.srgb_encode(np.array([-0.5, 2.0])), [0.0, 1.0], atol=1e-12)
    # 8-bit: round(255 x), clamped: 0.5 -> 127.5 -> 128 (half to even), 0.2 -> 51, 0.6 -> 153
    out = tonemap.to_uint8(np.array([0.0, 0.2, 0.5, 0.6, 1.0, 1.2, -0.1]))
    assert out.dtype == np.uint8
    np.testing.assert_array_equal(out, [0, 51, 128, 153, 255, 255, 0])


def test_luminance_weights_and_adaptation_of_a_coloured_map():
    from scenes.environment.directions import luminance

    # Rec. 709 / sRGB luminance: 0.2126 R + 0.7152 G + 0.0722 B
    np.testing.assert_allclose(luminance(np.eye(3)), [0.2126, 0.7152, 0.0722], rtol=1e-12)
    # a constant (2, 1, 4) map: L = 0.4252 + 0.7152 + 0.2888 = 1.4292; log-average = 1.4292 + delta
    env = np.tile(np.array([2.0, 1.0, 4.0], np.float32), (16, 32, 1))
    assert tonemap.adaptation_luminance(env) == pytest.approx(1.4292 + tonemap.LOG_DELTA, rel=1e-6)


def test_srgb_hand_values():
    # linear segment below 0.0031308, 1.055 x^(1/2.4) - 0.055 above (IEC 61966-2-1)
    assert tonemap.srgb_encode(0.002) == pytest.approx(0.02584, rel=1e-12)
    assert tonemap.srgb_encode(0.5) == pytest.approx(0.7353569830524495, rel=1e-9)
    assert tonemap.srgb_encode(1.0) == pytest.approx(1.0)


def test_tonemap_monotone_and_finite_at_extremes():
    x = np.concatenate([[0.0], np.logspace(-8, 9, 2000), [1e30, np.inf]])
    y = tonemap.tonemap(x, 0.18, 4.0, 0.0, 0.5)
    assert np.isfinite(y).all() and y[0] == 0.0 and y[-1] == 1.0
    assert (np.diff(y.astype(np.float64)) >= 0).all()


def test_adaptation_luminance_of_constant_map():
    # log-average of a constant radiance 1 map: exp(log(1 + delta)) = 1 + delta
    env = environments.builtin("constant")
    assert tonemap.adaptation_luminance(env) == pytest.approx(1.0 + tonemap.LOG_DELTA, rel=1e-9)
    assert tonemap.adaptation_luminance(env, scale=0.0) == pytest.approx(tonemap.LOG_DELTA, rel=1e-9)


def test_camera_rows_top_first_and_vertical_fov():
    cam = Camera(origin=(0, 0, 4), target=(0, 0, 0), up=(0, 1, 0), fov_deg=60.0, width=200, height=100)
    rays = cam.pixel_rays()
    # row 0 looks up (+Y), column 0 looks left (-X): right-handed, +Y up, looking down -Z
    assert rays[0, 100, 1] > 0 and rays[-1, 100, 1] < 0
    assert rays[50, 0, 0] < 0 and rays[50, -1, 0] > 0
    # the vertical field of view: the top edge of the image is 30 degrees above the axis, and row 0's centre
    # half a row below it: atan(tan 30 (1 - 1/100)) = 29.7513 degrees (the edge itself, 30, is a bug of 0.25)
    top_row = np.degrees(np.arctan2(np.tan(np.radians(30)) * (1 - 1 / 100), 1))
    assert top_row == pytest.approx(29.7513, abs=1e-4)
    assert np.degrees(np.arctan2(rays[0, 100, 1], -rays[0, 100, 2])) == pytest.approx(top_row, abs=1e-9)
    # project() inverts pixel_rays
    pts = np.asarray(cam.origin) + 3.0 * rays[[0, 10, 99], [0, 150, 199]]
    np.testing.assert_allclose(cam.project(pts), [[0.5, 0.5], [150.5, 10.5], [199.5, 99.5]], atol=1e-9)


def test_gl_matrices_agree_with_project():
    cam = Camera(origin=(1.0, 2.0, 3.0), target=(0.1, -0.2, 0.3), fov_deg=40.0, width=64, height=48)
    p = np.array([0.3, 0.1, -0.2, 1.0])
    clip = cam.projection_matrix(0.1, 100.0) @ cam.view_matrix() @ p
    ndc = clip[:3] / clip[3]
    # OpenGL: NDC y up, window row 0 at the bottom; iblcheck rows are top first
    expected = [(ndc[0] + 1) / 2 * 64, (1 - ndc[1]) / 2 * 48]
    np.testing.assert_allclose(cam.project(p[:3]), expected, atol=1e-9)


@pytest.mark.mitsuba
def test_mitsuba_to_world_equals_mitsubas_look_at(mi):
    cam = Camera(origin=(1.0, 2.0, 3.0), target=(0.1, -0.2, 0.3), up=(0.0, 1.0, 0.2))
    theirs = np.array(mi.ScalarTransform4f().look_at(origin=cam.origin, target=cam.target, up=cam.up).matrix)
    np.testing.assert_allclose(cam.mitsuba_to_world(), theirs, atol=1e-6)


def test_projection_maps_near_and_far_to_the_depth_range():
    """gluPerspective: a view-space point on the axis at distance near lands at NDC z = -1, at far at +1,
    and halfway in 1/z (2 near far / (near + far)) at 0."""
    cam = Camera(fov_deg=40.0, width=64, height=48)
    near, far = 0.5, 20.0
    P = cam.projection_matrix(near, far)
    for dist, ndc_z in [(near, -1.0), (far, 1.0), (2 * near * far / (near + far), 0.0)]:
        clip = P @ np.array([0.0, 0.0, -dist, 1.0])
        assert clip[2] / clip[3] == pytest.approx(ndc_z, abs=1e-12)

