"""The cube chain weighted by solid angle (EnvironmentFilter.solid_angle_chain), which voxel cone tracing reads.

The map: radiance 1 everywhere but a cap of 20 degrees about one axis, at 11. The cap lies inside the cube face
about that axis (whose edges are 45 degrees from its centre), so that face's mean radiance over its solid angle is
1 + 10 Omega_cap / Omega_face = 1 + 30 (1 - cos 20 deg) = 2.809, each other face's 1. The paper's 2x2 box chain
weighs the face's texels alike, so its 1x1 level holds 1 + 10 times the share of the face's texels inside the cap,
about pi tan^2(20 deg) / 4 of the face's area (the cap's gnomonic disc): 2.04, the negative control. Levels 0-3
hold texels too alike in solid angle near the cap to tell the two chains apart; levels 5-7 do.
"""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

import scenes
from realtime.engine.context import get_context
from realtime.engine.gpu import EnvironmentFilter
from realtime.techniques.vct.vct import VoxelScene
from scenes.environment import cubemap
from tests.helpers import CAP_HALF_ANGLE, cap_map

pytestmark = pytest.mark.gl

BASE = 128
CAP_COS = math.cos(CAP_HALF_ANGLE)
FACE_MEAN = 1.0 + 30.0 * (1.0 - CAP_COS)  # 2.809
BOX_MEAN = 1.0 + 10.0 * math.pi * math.tan(CAP_HALF_ANGLE) ** 2 / 4.0  # 2.041


def face_of(direction: tuple[float, float, float]) -> int:
    return int(cubemap.direction_to_face(np.asarray([direction], dtype=np.float64))[0][0])


def level_means(f: EnvironmentFilter, level: int) -> np.ndarray:
    """Per face, the weighted chain's mean radiance of the level's texels, each weighted by its solid angle: (6,)."""
    t = f.read_level(level, weighted=True)
    radiance = t[..., :3].mean(-1) / t[..., 3]
    omega = cubemap.texel_solid_angles(BASE >> level)
    return (radiance * omega).sum((1, 2)) / omega.sum()


@pytest.fixture(scope="module")
def zenith_cap():
    f = EnvironmentFilter(get_context(), cap_map((0.0, 1.0, 0.0)), BASE)
    f.fill_base(0.0)
    f.build_chain()
    yield f
    f.release()


@pytest.mark.parametrize("level", [0, 3, 5, 6, 7])
def test_every_level_keeps_each_faces_mean_radiance(zenith_cap, level):
    up = face_of((0.0, 1.0, 0.0))
    means = level_means(zenith_cap, level)
    assert means[up] == pytest.approx(FACE_MEAN, rel=0.01)
    assert np.delete(means, up) == pytest.approx(np.ones(5), abs=1e-6)


def test_the_coarsest_texel_is_the_faces_mean_where_the_box_chains_is_not(zenith_cap):
    up = face_of((0.0, 1.0, 0.0))
    top = int(math.log2(BASE))
    t = zenith_cap.read_level(top, weighted=True)[up, 0, 0]
    assert t[0] / t[3] == pytest.approx(FACE_MEAN, rel=0.01)
    assert t[3] == pytest.approx(4.0 * math.pi / 6.0 / BASE ** 2, rel=1e-5)  # the face's per base texel
    # control: the paper's box chain at the same level
    assert zenith_cap.read_level(top)[up, 0, 0, 0] == pytest.approx(BOX_MEAN, rel=0.01)


def test_the_chain_follows_each_fill():
    f = EnvironmentFilter(get_context(), cap_map((1.0, 0.0, 0.0)), BASE)
    try:
        top = int(math.log2(BASE))
        f.fill_base(0.0)
        before = level_means(f, top)
        f.fill_base(90.0)  # a quarter turn about +y takes the cap off the +x face
        after = level_means(f, top)
    finally:
        f.release()
    x = face_of((1.0, 0.0, 0.0))
    assert before[x] == pytest.approx(FACE_MEAN, rel=0.01)
    assert after[x] == pytest.approx(1.0, abs=1e-6)
    z = max(after[face_of((0.0, 0.0, 1.0))], after[face_of((0.0, 0.0, -1.0))])  # whichever way the turn goes
    assert z == pytest.approx(FACE_MEAN, rel=0.01)


@pytest.mark.parametrize("glossy", [True, False], ids=["glossy", "diffuse"])
def test_a_voxel_scene_binds_the_weighted_chain_where_a_glossy_surface_reads_it(glossy):
    """A plane voxelised under the zenith cap, the store passed as a frame passes it, the chain read as the cones
    read it (VoxelScene.read_environment: vct_glossy_env.glsl through bind_environment; the chain alone, without
    the broad-lobe table, which tests/realtime/test_vct_lobe_table.py checks). With a Phong plane it is
    the weighted chain: a lobe as wide as a hemisphere (N = 0, the level clamped to the 1x1 faces) along +y reads
    the +y face's mean, 2.809, along +x 1; a sharp lobe (N = 1e6, level 0) toward a cube corner, where a base
    texel covers 0.37 of the mean texel's solid angle, reads 1 (the read divides the weight out). With a diffuse
    plane nothing reads the environment, the weighted chain is never built, and the sampler holds the paper's
    cube: +y reads its box mean, 2.04 (the control)."""
    ctx = get_context()
    f = EnvironmentFilter(ctx, cap_map((0.0, 1.0, 0.0)), BASE)
    plane = scenes.load("builtin:sphere-on-plane").objects[1]
    material = (dataclasses.replace(scenes.load("builtin:torus-phong").objects[0].material, exponent=50.0)
                if glossy else plane.material)
    corner = 1.0 / math.sqrt(3.0)
    vs = None
    try:
        f.fill_base(0.0)
        f.build_chain()
        f.project_sh(64)
        vs = VoxelScene(ctx, [SimpleNamespace(mesh=plane.mesh, material=material)], 16, 1, 6, 0.5, env_filter=f)
        vs.update(None, f.sh_buffer)
        reads = vs.read_environment(np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [corner, corner, corner]]),
                                    np.array([0.0, 0.0, 1e6]), table=False)[:, 0]
        built = f.solid_angle_cube is not None
    finally:
        if vs is not None:
            vs.release()
        f.release()
    assert built == glossy
    if glossy:
        assert reads == pytest.approx([FACE_MEAN, 1.0, 1.0], rel=0.01)
    else:
        assert reads[0] == pytest.approx(BOX_MEAN, rel=0.01)
