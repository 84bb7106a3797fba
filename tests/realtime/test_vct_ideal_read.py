"""The ideal cone read's model (realtime/techniques/vct/vct_ideal_read.py): numpy cases by hand, and under a sphere
above a plane the model against the exact visibility and against the shading's own cone (GL)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import scenes
from realtime.engine.context import get_context
from realtime.techniques.vct import vct_math
from realtime.techniques.vct.vct import NORMAL_OFFSET_VOXELS, START_OFFSET_VOXELS
from realtime.techniques.vct.vct_ideal_read import ideal_axis_cone_occlusion
from tests.helpers import scene_voxels

RES = 64
TAN30 = math.tan(math.radians(30.0))


def up_cone(alpha: np.ndarray) -> float:
    # a 60-degree cone up (+y) from the middle of the grid's floor, grid [0, 1]^3
    h = 1.0 / RES
    return ideal_axis_cone_occlusion(alpha, h, np.zeros(3), np.array([0.5, 2 * h, 0.5]), 1, 1, TAN30, h, h)


def test_empty_grid_occludes_nothing():
    assert up_cone(np.zeros((RES, RES, RES))) == 0.0


def test_opaque_layer_across_the_grid_blocks_the_cone():
    alpha = np.zeros((RES, RES, RES))
    alpha[:, 40, :] = 1.0
    assert up_cone(alpha) > 0.999


def test_layer_over_half_the_columns_blocks_about_half():
    # the layer covers the columns x < 0.5, the cone's axis is at x = 0.5: every box holding the layer reads 0.5,
    # and a box is charged half its depth's optical depth per step of half its width, so the boxes that hold
    # the one-voxel layer (about two) pass (1 - 0.5)^(1/2) each: about 0.5 in all
    alpha = np.zeros((RES, RES, RES))
    alpha[: RES // 2, 40, :] = 1.0
    assert up_cone(alpha) == pytest.approx(0.5, abs=0.1)
    # control: the layer over the other half reads the same, the whole layer twice its optical depth
    other = np.zeros((RES, RES, RES))
    other[RES // 2:, 40, :] = 1.0
    assert up_cone(other) == pytest.approx(up_cone(alpha), abs=0.05)


@pytest.mark.gl
def test_ideal_read_meets_the_sphere_criterion_where_the_shading_cone_does_not():
    """A sphere of radius 0.5 one diameter above a plane (centre at 1.5) at 64^3: the exact cosine-weighted
    share blocked is (r / h)^2 = 11.1 %, nearly all of it inside the six-cone set's up cone (the sphere's 19.5
    degrees reach 3 degrees into the ring's caps, which start 16.3 degrees from the normal). The ideal read of the
    up cone alone, times its weight, gives the set within 3 points of it; the shading's own cone, traced through
    the same voxels, reads the whole cone blocked (23.3 %, the up cone's whole weight)."""
    scene = scenes.load("builtin:sphere-on-plane").with_overrides({"objects.0.translate": [0.0, 1.5, 0.0]})
    vs = scene_voxels(get_context(), scene, RES)
    g = vs.grid
    h = g.voxel_size
    alpha = vs.read_faces(0)[3, 0, ..., 3]  # what leaves toward -y: the faces against a cone going up
    cones = vct_math.cone_set(6)
    tan_half = math.tan(cones.half_angle)
    origin = np.array([0.0, NORMAL_OFFSET_VOXELS * h, 0.0])
    grid_min = np.asarray(g.centre) - g.half_extent
    a_ideal = ideal_axis_cone_occlusion(alpha, h, grid_min, origin, 1, 1, tan_half, START_OFFSET_VOXELS * h, h)
    a_shading = vs.trace_cone(origin[None], np.array([[0.0, 1.0, 0.0]]), np.array([tan_half]),
                              np.array([START_OFFSET_VOXELS * h]), np.zeros((1, 3)), np.array([[0.0, 1.0, 0.0]]))[0, 3]
    vs.release()
    exact = 100.0 * (1.0 - vct_math.cap_visibility(0.5, 1.5))
    share = 100.0 * cones.weights[0] / math.pi  # the up cone's share of the cosine lobe
    assert exact == pytest.approx(100.0 / 9.0)
    assert abs(share * a_ideal - exact) <= 3.0, (share * a_ideal, exact)
    assert abs(share * a_shading - exact) > 3.0, (share * a_shading, exact)  # negative control
