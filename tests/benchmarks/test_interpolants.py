"""benchmarks/gpu/interpolants.py: the rasteriser's interpolated normal and position against the ray cast's.

A fragment's attributes are the barycentric blend of its triangle's vertices at the point where the pixel centre's
ray meets it (perspective-correct interpolation), which the ray cast computes in float64. Away from the silhouette
(2 px in) a GL meets it to float32's precision at the scene's scale (positions near 4 units carry 4 * 2^-23 =
4.8e-7; 1e-5 leaves twenty times that) plus what snapping the vertices to its sub-pixel grid may move: OpenGL lets
a rasteriser place vertices on a grid of 2^-GL_SUBPIXEL_BITS px (at least 4 bits), and a vertex moved by half a
step moves the interpolants as a sample moved by that much would, the ray cast's own change per pixel times
2^-(bits + 1). On llvmpipe (8 bits) that allows 7e-4, where it meets the ray cast to 6e-7. The control
samples another point of each pixel (the field of view 0.1 % wider moves it up to 0.03 px at the sphere's edge)
and must miss by twice the bound (it misses by 2.7e-3 on llvmpipe).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

import scenes
from groundtruth.exact import raycast
from realtime.engine.context import get_context

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("interpolants", ROOT / "benchmarks" / "gpu" / "interpolants.py")
interpolants = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = interpolants
_spec.loader.exec_module(interpolants)

pytestmark = pytest.mark.gl

SPEC, SIZE = "builtin:sphere-phong", 64
FLOAT_BOUND = 1e-5


def bound() -> float:
    """FLOAT_BOUND plus the most a vertex snapped to this GL's sub-pixel grid can move the interpolants: the ray
    cast's largest change per pixel (its 2 x 2 sub-pixel rays, half a pixel apart), normal angle or position,
    times half a grid step."""
    scene = scenes.load(SPEC).with_overrides({"camera.width": SIZE, "camera.height": SIZE})
    hits = raycast.cast(scene, subpixels=2)
    inner = hits.hit.all(axis=-1)
    n, p = hits.normal, hits.position  # (H, W, 4, 3): sub-samples (row, column) (0, 0), (0, 1), (1, 0), (1, 1)
    change = 0.0
    for a, b in ((0, 1), (2, 3), (0, 2), (1, 3)):  # neighbours half a pixel apart
        angle = np.arccos(np.clip(np.sum(n[..., a, :] * n[..., b, :], axis=-1), -1.0, 1.0))
        step = np.linalg.norm(p[..., a, :] - p[..., b, :], axis=-1)
        change = max(change, float(angle[inner].max()) / 0.5, float(step[inner].max()) / 0.5)
    bits = int(get_context().info.get("GL_SUBPIXEL_BITS") or 4)  # 4: the least OpenGL allows
    return FLOAT_BOUND + change * 2.0 ** -(bits + 1)


def test_the_gl_interpolates_at_the_pixel_centre_as_the_ray_cast_does():
    result = interpolants.measure(SPEC, SIZE)
    assert result["pixels_inner"] > 2000 and result["coverage_disagrees"] <= 0.01 * result["pixels_both"]
    inner, limit = result["inner"], bound()
    assert inner["normal_angle"]["max"] < limit, (inner, limit)
    assert inner["position"]["max"] < limit, (inner, limit)


def test_control_another_sample_point_misses(monkeypatch):
    """The ray cast through a camera whose field of view is 0.1 % wider: its rays pass up to 0.03 px from the
    pixel centres the GL sampled, and its normals and positions must then miss by more than the bound."""
    cast = raycast.cast

    def wider(scene, subpixels: int = 1):
        return cast(scene.with_overrides({"camera.fov_deg": scene.camera.fov_deg * 1.001}), subpixels)

    limit = bound()
    monkeypatch.setattr(interpolants.raycast, "cast", wider)
    inner = interpolants.measure(SPEC, SIZE)["inner"]
    assert inner["normal_angle"]["max"] > 2 * limit, (inner, limit)
    assert inner["position"]["max"] > 2 * limit, (inner, limit)
