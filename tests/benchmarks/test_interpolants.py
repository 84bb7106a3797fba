"""benchmarks/gpu/interpolants.py: the rasteriser's interpolated normal and position against the ray cast's.

A fragment's attributes are the barycentric blend of its triangle's vertices at the point where the pixel centre's
ray meets it (perspective-correct interpolation), which the ray cast computes in float64. Away from the silhouette
(2 px in), a GL that samples the pixel centre and interpolates in float32 meets it to float32's precision at the
scene's scale: positions near 4 units carry 4 * 2^-23 = 4.8e-7, so 1e-5 in position and in the normal's angle
leaves twenty times that. The control samples another point of each pixel (the field of view 0.1 % wider moves it
up to 0.03 px at the sphere's edge) and must miss by far more: it misses by up to 2.7e-3 on llvmpipe.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("interpolants", ROOT / "benchmarks" / "gpu" / "interpolants.py")
interpolants = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = interpolants
_spec.loader.exec_module(interpolants)

pytestmark = pytest.mark.gl

FLOAT_BOUND = 1e-5


def test_the_gl_interpolates_at_the_pixel_centre_as_the_ray_cast_does():
    result = interpolants.measure("builtin:sphere-phong", 64)
    assert result["pixels_inner"] > 2000 and result["coverage_disagrees"] <= 0.01 * result["pixels_both"]
    inner = result["inner"]
    assert inner["normal_angle"]["max"] < FLOAT_BOUND, inner
    assert inner["position"]["max"] < FLOAT_BOUND, inner


def test_control_another_sample_point_misses(monkeypatch):
    """The ray cast through a camera whose field of view is 0.1 % wider: its rays pass up to 0.03 px from the
    pixel centres the GL sampled, and its normals and positions must then miss by far more than the bound."""
    cast = interpolants.raycast.cast

    def wider(scene, subpixels: int = 1):
        return cast(scene.with_overrides({"camera.fov_deg": scene.camera.fov_deg * 1.001}), subpixels)

    monkeypatch.setattr(interpolants.raycast, "cast", wider)
    inner = interpolants.measure("builtin:sphere-phong", 64)["inner"]
    assert inner["normal_angle"]["max"] > 20 * FLOAT_BOUND, inner
    assert inner["position"]["max"] > 20 * FLOAT_BOUND, inner
