"""Camera.depth_range: the near and far planes of the real-time projection.

A 24-bit depth buffer stores round(d 2^24) of the window depth d = (ndc_z + 1) / 2; two surfaces tie where
they round alike. The expectations here come from gluPerspective's matrix applied to points in eye space,
not from depth_range's own formula.
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


@pytest.mark.parametrize("seed", range(5))
def test_every_vertex_lies_between_the_planes(seed):
    rng = np.random.default_rng(seed)
    cam = Camera(origin=tuple(rng.normal(size=3) * 5), target=tuple(rng.normal(size=3) * 0.2))
    forward = cam.basis()[2]
    objects = []
    for _ in range(3):  # point clouds 1 to 10 units ahead of the camera
        pts = rng.normal(size=(200, 3)) * 0.3 + np.asarray(cam.origin) + forward * rng.uniform(1.0, 10.0)
        objects.append(pts)
    near, far = cam.depth_range(objects)
    d = window_depth(cam, near, far, np.concatenate(objects))
    assert d.min() > 0.0 and d.max() < 1.0
    least = min(float(((p - np.asarray(cam.origin)) @ forward).min()) for p in objects)
    assert near == pytest.approx(0.9 * least)


def test_a_vertex_behind_the_camera_keeps_the_near_plane_small():
    cam = Camera(origin=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0))
    inside = np.array([[0.0, 0.0, 2.0], [0.0, 0.0, -3.0], [1.0, 0.0, -1.0]])  # spans the camera
    near, far = cam.depth_range([inside])
    assert far == pytest.approx(1.01 * 3.0) and near == pytest.approx(3.0e-4)
    assert window_depth(cam, near, far, np.array([[0.0, 0.0, -0.01]]))[0] > 0.0  # 1 cm ahead is not clipped


def test_the_bowls_rim_and_the_wall_behind_it_no_longer_tie():
    """bowl-diffuse's rim pixels: a back-facing wall 1e-3 behind the rim at eye depth about 4. With the near
    plane at far x 1e-4 the 24-bit buffer steps by about z^2 / (near 2^24) = 2e-3 there and the two tie (the
    negative control); with depth_range's near plane they are thousands of steps apart (7129)."""
    scene = scenes.load("builtin:bowl-diffuse")
    cam = scene.camera
    near, far = cam.depth_range([o.mesh.positions for o in scene.objects])
    forward = cam.basis()[2]
    rim = np.asarray(cam.origin) + forward * 4.0
    pair = np.stack([rim, rim + forward * 1e-3])

    def steps(n: float) -> float:
        d = window_depth(cam, n, far, pair)
        return float(np.diff(d)[0] * 2**BITS)

    assert steps(near) > 10.0
    assert steps(far / 1.01 * 1e-4) < 1.0
