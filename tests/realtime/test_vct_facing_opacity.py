"""A texel's coverage blocks a cone only where a surface covering that axis faces the cone
(vct_trace.glsl's vct_facing_axes), against the geometry's own answer:

- a cone leaving the front of a one-sided wall, moving away from it, meets nothing (a ray reaches the wall's
  back only from behind it): its occlusion is 0, though the coarse texels it reads hold the wall;
- a cone moving into that wall's front is blocked (occlusion above 0.99), and so is a cone moving into
  either side of a two-sided wall, each side facing one of them; a cone crossing the one-sided wall from
  behind is blocked too (the path tracer's rays stop at a back as well): the finer read, which keeps
  every surface's coverage, finds the wall on the cone's axis.

Negative control: without the facing test (every axis's coverage counted, as the backs' were) the cone moving
away from the wall reads it as an occluder.
"""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

import scenes
from realtime.engine.context import get_context
from realtime.engine.gpu import shader_source
from realtime.techniques.vct import vct_math
from tests.helpers import scene_voxels

pytestmark = pytest.mark.gl

PACKAGE = "realtime.techniques.vct"
#: the facing test in vct_read, and the same line without it (the control)
FACING = "alphas = clamp(vec3(x.a, y.a, z.a), 0.0, 1.0) * vct_facing_axes(mx, my, mz, qx, qy, qz, d);"
NO_FACING = "alphas = clamp(vec3(x.a, y.a, z.a), 0.0, 1.0);"
WALL_X = 0.2
#: the cones start this far in front of the wall (its front side, x < WALL_X)
ORIGIN = np.array([0.1, 0.0, 0.0])
#: the six diffuse cones' tan(half-angle): wide, so that they read coarse texels holding the wall early on
TAN_HALF = math.tan(vct_math.cone_set(6).half_angle)


@pytest.fixture(scope="module")
def ctx():

    return get_context()


def wall(two_sided: bool) -> SimpleNamespace:
    """The plane x = WALL_X, 2 x 2 about the x axis, its normal -x (its front toward ORIGIN)."""
    scene = scenes.load("builtin:sphere-diffuse")
    material = dataclasses.replace(scene.objects[0].material, two_sided=two_sided)
    positions = [[WALL_X, -1.0, -1.0], [WALL_X, 1.0, -1.0], [WALL_X, 1.0, 1.0], [WALL_X, -1.0, 1.0]]
    mesh = SimpleNamespace(positions=np.asarray(positions, "f8"), indices=np.asarray([[0, 2, 1], [0, 3, 2]], "i4"),
                           normals=np.tile([-1.0, 0.0, 0.0], (4, 1)))
    return SimpleNamespace(mesh=mesh, material=material)


def occlusion(ctx, two_sided: bool, d, origin=ORIGIN, control: bool = False) -> float:
    """The occlusion of one cone from `origin` along d at 32^3 (voxel 0.069), uncapped: the surface it leaves
    is put 100 units behind it, so every sample reads the cone's own level."""
    scene = scenes.load("builtin:sphere-diffuse")
    vs = scene_voxels(ctx, scene, 32, [wall(two_sided)], vct_math.Cascades((0.0, 0.0, 0.0), 1.1, 32, 1))
    if control:
        src = shader_source("vct_cone.comp", package=PACKAGE)
        if FACING not in src:
            raise AssertionError("the facing test is no longer in vct_read")
        vs.cone_prog = ctx.compute_shader(src.replace(FACING, NO_FACING))
    d = np.asarray(d, "f8") / np.linalg.norm(d)
    o = np.asarray(origin, "f8")
    r = vs.trace_cone(o[None], d[None], np.array([TAN_HALF]), np.array([vs.grid.voxel_size]),
                      (o - 100.0 * d)[None], d[None])[0]
    vs.release()
    return float(r[3])


@pytest.mark.parametrize("control", [False, True])
@pytest.mark.parametrize("d", [(-1.0, 0.0, 0.0), (-0.8, 0.6, 0.0), (-0.6, -0.3, 0.7)])
def test_a_cone_moving_away_from_a_walls_front_is_not_blocked_by_it(ctx, d, control):
    a = occlusion(ctx, False, d, control=control)
    assert (a < 1e-3) == (not control), a


@pytest.mark.parametrize(("two_sided", "origin", "d"), [
    (False, ORIGIN, (1.0, 0.3, 0.0)),
    (True, ORIGIN, (1.0, 0.3, 0.0)),
    (True, 2.0 * WALL_X - ORIGIN, (-1.0, 0.3, 0.0)),  # into its other side, from behind
    (False, 2.0 * WALL_X - ORIGIN, (-1.0, 0.3, 0.0)),  # into a one-sided wall's back
])
def test_a_cone_moving_into_a_wall_is_blocked(ctx, two_sided, origin, d):
    assert occlusion(ctx, two_sided, d, origin=np.asarray(origin, "f8")) > 0.99
