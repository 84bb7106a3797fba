"""Which surface the real-time renderer shows at a pixel: the first one along the pixel's ray.

The numpy ray cast (groundtruth/exact/raycast.py) finds each pixel centre's first hit on the same meshes and
says whether its shading normal faces the viewer; the one-sided rule (scenes/model/materials.py) makes the
real-time pixel black exactly where it does not. A black pixel where the ray cast finds a front-facing first
hit is a back face that won the depth test against a nearer front face.

The projection's near plane n sets the depth buffer's step: z^2 (f - n) / (f n 2^24) at eye depth z. With a
near plane of far x 1e-4 it was 2e-3 at 4 units, and at bowl-diffuse's rim (a back-facing wall 1-2.5e-3 behind
the rim) and on rook-phong, pawn-blend and spheres-pbr-metal a back face won at 2-10 pixels of 192^2.
Camera.depth_range puts the near plane at 0.9 x the least eye depth of any vertex; the control puts it back.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import realtime
import scenes
from scenes.model.camera import Camera
from tests.helpers import predicted_back

pytestmark = pytest.mark.gl
SIZE = 192


def black_and_back(spec: str, **overrides) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(real-time pixels black and covered, ray cast's first hit facing away, covered by both) at SIZE^2."""
    s = scenes.load(spec).with_overrides({"camera.width": SIZE, "camera.height": SIZE,
                                          "realtime.timing_frames": 1, "realtime.warmup_frames": 0, **overrides})
    hit, back = predicted_back(s)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the scenes' unsimulated effects are not the point here
        r = realtime.render(s)
    return r.mask & (r.rgb.max(axis=-1) == 0), back, r.mask & hit


@pytest.mark.parametrize("spec", [
    "builtin:cornell-open", "builtin:sphere-on-plane", "builtin:torus-phong", "builtin:bowl-diffuse",
    "builtin:rook-phong", "builtin:teapot-blend", "builtin:thin-wall", "builtin:pawn-blend", "builtin:pawn-pbr",
    "builtin:spheres-pbr-metal", "builtin:spheres-pbr-dielectric",
])
def test_no_pixel_is_black_where_the_first_hit_faces_the_viewer(spec):
    black, back, both = black_and_back(spec)
    assert both.sum() > 1000
    wrong = np.argwhere(black & both & ~back)
    assert len(wrong) == 0, f"{len(wrong)} pixels black over a front-facing first hit, e.g. {wrong[:5].tolist()}"


def test_the_check_finds_the_ties_of_a_near_plane_at_far_x_1e_4(monkeypatch):
    # control: the near plane put back where it was, bowl-diffuse's rim shows back faces over front-facing hits
    def near_at_far_x_1e_4(self: Camera, positions) -> tuple[float, float]:
        far = original(self, positions)[1]
        return far / 1.01 * 1e-4, far

    original = Camera.depth_range
    monkeypatch.setattr(Camera, "depth_range", near_at_far_x_1e_4)
    black, back, both = black_and_back("builtin:bowl-diffuse")
    assert (black & both & ~back).sum() >= 3


def test_the_check_sees_black_pixels_where_the_first_hit_faces_away():
    # control: a one-sided plane seen from below is black wherever it covers, and the ray cast says so
    black, back, both = black_and_back("builtin:sphere-blend", **{"objects.0.shape": "plane",
                                                                 "camera.origin": [0.0, -2.0, 2.5]})
    assert both.sum() > 1000
    assert np.array_equal(black & both, back & both)
