"""The split sum through the whole frame (realtime.render): a sphere of glTF's pbr material in a constant
environment of radiance 1 (a white furnace). The prefiltered radiance is then 1 at every level, so each
pixel is the DFG table's F_ibl at that pixel's n.v: for a metal of base_color 1 without multiple-scattering
compensation the lobe's albedo A + B, with it exactly 1; for a black dielectric 0.04 A + B. The
expectations come from the quadrature of test_split_sum_tables at the pixel's analytic n.v (the unit
sphere hit by the pixel-centre ray), not from the table."""

from __future__ import annotations

import numpy as np
import pytest

import realtime
import scenes
from tests.helpers import sphere_scene_text, unit_sphere_hits, write_scene
from tests.realtime.test_split_sum_tables import quadrature_ab

pytestmark = pytest.mark.gl

SIZE = 48
SMALL = {"realtime.split_sum.recipe": "custom", "realtime.split_sum.sampling": "importance",
         "realtime.split_sum.samples": 32, "realtime.split_sum.double_samples": False,
         "realtime.split_sum.fis_bias": 0.0, "realtime.split_sum.lod_mapping": "linear",
         "realtime.split_sum.size": 16, "realtime.split_sum.min_size": 4, "realtime.split_sum.lut_size": 32,
         "realtime.split_sum.lut_samples": 512, "realtime.split_sum.lut_precision": "f32",
         "realtime.split_sum.visibility": "height_correlated", "realtime.split_sum.multiscatter": "none",
         "realtime.base_size": 16, "realtime.face_size": 16, "realtime.timing_frames": 1,
         "realtime.warmup_frames": 0}


def furnace(tmp_path, material: str, **overrides):
    text = sphere_scene_text("furnace", 'map = "builtin:constant"', material, SIZE,
                             tables='[realtime]\ndiffuse = "sh"\nglossy = "split_sum"\n')
    scene = scenes.load(write_scene(tmp_path, text)).with_overrides({**SMALL, **overrides})
    r = realtime.render(scene)
    normals, views, interior = unit_sphere_hits(scene.camera, margin_px=2.5)
    nv = np.sum(normals * views, axis=-1)
    keep = interior & r.mask & (nv > 0.2)
    assert keep.sum() > 0.3 * SIZE * SIZE
    return r.rgb[keep].astype(np.float64), nv[keep]


def quadrature_curve(roughness: float, f0: float, nv: np.ndarray) -> np.ndarray:
    """f0 A + B by the quadrature on a grid of n.v, linearly interpolated (E is smooth in n.v above 0.2:
    the grid's interpolation error is below 1e-4)."""
    grid = np.linspace(0.2, 1.0, 33)
    ab = np.array([quadrature_ab(x, roughness, nodes=160) for x in grid])
    return np.interp(nv, grid, f0 * ab[:, 0] + ab[:, 1])


METAL = '{ type = "pbr", base_color = [1.0, 1.0, 1.0], metallic = 1.0, roughness = %s }'


@pytest.mark.parametrize("roughness", [0.2, 0.5, 0.9])
def test_a_white_metal_in_a_white_furnace_shows_the_lobes_albedo(tmp_path, roughness):
    """Each pixel = A + B at its n.v (within 6e-3: the 32^2 table's bilinear interpolation, its 512
    samples and the mesh's interpolated normals; measured 2.2e-3, 2.4e-3, 3.3e-3). The same check rejects
    a metal of base_color 0.9 (F0 A + B, 0.1 A lower; the control)."""
    rgb, nv = furnace(tmp_path, METAL % roughness)
    want = quadrature_curve(roughness, 1.0, nv)
    err = np.abs(rgb - want[:, None]).max()
    print(f"roughness {roughness}: max |pixel - (A + B)| = {err:.2e}")
    assert err < 6e-3
    grey = METAL.replace("[1.0, 1.0, 1.0]", "[0.9, 0.9, 0.9]") % roughness
    rgb_grey, nv_grey = furnace(tmp_path, grey)
    assert np.abs(rgb_grey - quadrature_curve(roughness, 1.0, nv_grey)[:, None]).max() > 6e-3


@pytest.mark.parametrize("multiscatter", ["fdez_aguera", "threejs", "filament"])
def test_with_multiple_scattering_the_furnace_keeps_all_its_energy(tmp_path, multiscatter):
    """F0 = 1: Ess + Ems = 1 at every pixel, to float32 rounding (the prefiltered constant and F_ibl's
    algebra); without compensation the same check fails by 1 - (A + B) (the control)."""
    rgb, _ = furnace(tmp_path, METAL % 0.9, **{"realtime.split_sum.multiscatter": multiscatter})
    np.testing.assert_allclose(rgb, 1.0, atol=2e-5)
    rgb_none, _ = furnace(tmp_path, METAL % 0.9)
    assert np.abs(rgb_none - 1.0).max() > 0.1


def test_a_black_dielectric_shows_the_fresnel_of_f0_0_04(tmp_path):
    """base_color 0, metallic 0: no Lambert term, so each pixel is F_ibl(0.04) = 0.04 A + B. A metal's F0
    (the dielectric read as F0 = 1, the control) is far above it."""
    material = '{ type = "pbr", base_color = [0.0, 0.0, 0.0], metallic = 0.0, roughness = 0.5 }'
    rgb, nv = furnace(tmp_path, material)
    want = quadrature_curve(0.5, 0.04, nv)
    assert np.abs(rgb - want[:, None]).max() < 3e-3
    assert np.abs(rgb - quadrature_curve(0.5, 1.0, nv)[:, None]).min() > 0.3


def test_a_coloured_metal_takes_f0_per_channel(tmp_path):
    """base_color (1, 0.5, 0): F_ibl = F0 A + B per channel."""
    material = '{ type = "pbr", base_color = [1.0, 0.5, 0.0], metallic = 1.0, roughness = 0.5 }'
    rgb, nv = furnace(tmp_path, material)
    for c, f0 in enumerate((1.0, 0.5, 0.0)):
        assert np.abs(rgb[:, c] - quadrature_curve(0.5, f0, nv)).max() < 6e-3, c
