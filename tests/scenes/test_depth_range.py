"""Camera.depth_range: the near and far planes of the real-time projection.

A 24-bit depth buffer stores round(d 2^24) of the window depth d = (ndc_z + 1) / 2; two surfaces tie where
they round alike. The expectations here come from gluPerspective's matrix applied to points in eye space
(Camera.projection_matrix, itself checked in test_tonemap_camera.py), not from depth_range's formula.
"""

from __future__ import annotations

import numpy as np
import pytest

import scenes
from scenes.model.camera import Camera

BITS = 24


def window_depth(cam: Camera, near: float, far: float, points: np.ndarray) -> np.ndarray:
    """The window depth in [0, 1] of world points, through the view and projection matrices."""
    h = np.c_[points, np.ones(len(points))] @ (cam.projection_matrix(near, far) @ cam.view_matrix()).T
    return (h[:, 2] / h[:, 3] + 1.0) / 2.0


def eye_depth(cam: Camera, points: np.ndarray) -> np.ndarray:
    return (np.asarray(points) - np.asarray(cam.origin)) @ cam.basis()[2]


@pytest.mark.parametrize("seed", range(5))
def test_every_vertex_lies_between_the_planes_and_the_near_plane_is_close_to_the_nearest(seed):
    rng = np.random.default_rng(seed)
    cam = Camera(origin=tuple(rng.normal(size=3) * 5), target=tuple(rng.normal(size=3) * 0.2))
    forward = cam.basis()[2]
    objects = [rng.normal(size=(200, 3)) * 0.3 + np.asarray(cam.origin) + forward * rng.uniform(1.0, 10.0)
               for _ in range(3)]  # point clouds 1 to 10 units ahead of the camera
    near, far = cam.depth_range(objects)
    d = window_depth(cam, near, far, np.concatenate(objects))
    assert d.min() > 0.0 and d.max() < 1.0  # nothing clipped
    least = min(float(eye_depth(cam, p).min()) for p in objects)
    assert 0.5 * least < near < least  # and the near plane not needlessly close (the step is z^2 / near)


@pytest.mark.parametrize("behind", [
    np.array([[0.0, 0.0, 2.0], [0.0, 0.0, -3.0], [1.0, 0.0, -1.0]]),  # one object spanning the camera
    np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -3.0], [1.0, 0.0, -1.0]]),  # a vertex at the camera itself
], ids=["spanning", "at-the-camera"])
def test_a_vertex_at_or_behind_the_camera_keeps_the_near_plane_small(behind):
    cam = Camera(origin=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0))
    ahead = np.array([[0.0, 0.0, -2.0], [0.5, 0.0, -2.5], [0.0, 0.5, -2.2]])  # a second object, well ahead
    near, far = cam.depth_range([ahead, behind])
    assert far == pytest.approx(1.01 * 3.0) and near == pytest.approx(3.0e-4)
    assert window_depth(cam, near, far, np.array([[0.0, 0.0, -0.01]]))[0] > 0.0  # 1 cm ahead is not clipped


def test_a_vertex_very_close_ahead_is_not_clipped():
    cam = Camera(origin=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0))
    pts = np.array([[0.0, 0.0, -1e-6], [0.0, 0.0, -5.0], [1.0, 0.0, -3.0]])
    near, far = cam.depth_range([pts])
    assert window_depth(cam, near, far, pts).min() > 0.0


def test_no_vertices_give_the_unit_range():
    cam = Camera()
    assert cam.depth_range([]) == pytest.approx((1e-4, 1.01))
    assert cam.depth_range([np.zeros((0, 3))]) == pytest.approx((1e-4, 1.01))


def test_two_surfaces_1e_3_apart_at_the_bowls_rim_depth_no_longer_tie():
    """bowl-diffuse's rim pixels show a back-facing wall 1e-3 behind the rim, at eye depth about 4. Two points
    on the view axis at that depth and 1e-3 apart: with the near plane at far x 1e-4 the 24-bit buffer's step
    there, z^2 (f - n) / (f n 2^24) = 2e-3, holds both in one step (the negative control, where the ties came
    from); with depth_range's near plane (2.74) they lie thousands of steps apart."""
    scene = scenes.load("builtin:bowl-diffuse")
    cam = scene.camera
    near, far = cam.depth_range([o.mesh.positions for o in scene.objects])
    forward = cam.basis()[2]
    at_rim = np.asarray(cam.origin) + forward * 4.0
    pair = np.stack([at_rim, at_rim + forward * 1e-3])

    def steps(n: float) -> float:
        return float(np.diff(window_depth(cam, n, far, pair))[0] * 2**BITS)

    assert steps(near) > 1000.0
    assert steps(far / 1.01 * 1e-4) < 1.0
