"""The deferred glossy read (vct_trace.glsl's vct_gloss_radiance): a cone reading a glossy surface gathers what the
surface reflects toward the cone, the environment taken about the mirror of the cone's own direction, not about
the directions of the six faces the voxels store.

A horizontal Phong plane (ks 0.8, N 50) alone under an environment whose radiance is linear in the direction,
L(w) = 1 + w_x. The normalised Phong lobe P about r has the first moment int P(l) l dl = k r, k = (N + 1) / (N + 2)
(its mean of r . l; the parts across r cancel), so it averages L to L_g(r) = 1 + k r_x. A narrow cone looking down
at the plane along d, 40 degrees off the vertical toward +x and toward -x, sees r = reflect(d, +y) 40 degrees from
the zenith, the lobe wholly above the horizon (its share below is under 1e-9 for N = 50), so it gathers
ks (1 + k r_x) with r_x = -sin 40 and +sin 40. The two readings give the constant term (their mean, ks) and k
(their half difference over ks sin 40).

The store's chain stands in for the lobe with a box of texels of the lobe's solid angle a^2 = 2 pi / (N + 1), read
trilinearly: per axis the box's variance a^2 / 12 and the interpolation's tent's a^2 / 6 add a^2 / 2 of angular
variance, which shrinks the first moment by about 1 - a^2 / 4: k about 0.981 x 0.969 = 0.951. So k lies between
that estimate and the exact lobe's 0.981 (measured 0.956 on the cube, 0.969 on the dual paraboloid, 0.972 on the
sphere map), for each of the environment store's parameterizations, which the read looks up through its own
uniforms; the constant term within 1 % of ks.

Control: the six-face storage (`deferred_glossy=False`) stores in the +Y face the radiance toward +y,
ks L_g(+y) = ks, and reads it whichever way the cone looks: k = 0, outside the band.
"""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

import scenes
from realtime.engine.context import get_context
from realtime.engine.environment_maps import environment_store
from realtime.techniques.vct import vct_math
from realtime.techniques.vct.vct import VoxelScene
from scenes.environment import directions, envmap

pytestmark = pytest.mark.gl

KS, N_EXP = 0.8, 50.0
TILT_DEG = 40.0
#: the cone's half-angle: narrow, so that it meets the plane within a few voxels of its axis
TAN_HALF = math.tan(math.radians(5.0))


@pytest.fixture(scope="module")
def linear_sky(tmp_path_factory) -> str:
    """An environment map of radiance 1 + w_x in every channel (w the pixel's direction)."""
    d = directions.equirect_directions(128, 256)
    path = tmp_path_factory.mktemp("env") / "linear_x.exr"
    envmap.write(path, np.repeat(1.0 + d[..., :1], 3, axis=-1).astype(np.float32))
    return str(path)


def gathered(linear_sky: str, parameterization: str, deferred: bool) -> np.ndarray:
    """Radiance (2,) the narrow cone gathers from the plane looking down 40 degrees off the vertical, toward -x
    (its mirror direction toward +x) and toward +x, the grey mean of rgb."""
    ctx = get_context()
    scene = scenes.load("builtin:sphere-on-plane").with_overrides({
        "environment.map": linear_sky, "realtime.parameterization": parameterization})
    env = environment_store(ctx, scene)
    env.fill_base(scene.environment.rotation_deg)
    env.build_chain(None)
    env.project_sh(64)
    phong = dataclasses.replace(scenes.load("builtin:torus-phong").objects[0].material, ks=(KS,) * 3,
                                exponent=N_EXP)
    plane = SimpleNamespace(mesh=scene.objects[1].mesh, material=phong)
    grid = vct_math.Cascades((0.0, 0.5 * 4.4 / 32, 0.0), 2.2, 32, 1)
    vs = VoxelScene(ctx, [plane], 32, 1, 6, 0.5, grid=grid, env_filter=env, deferred_glossy=deferred)
    vs.update(None, env.sh_buffer)
    s, c = math.sin(math.radians(TILT_DEG)), math.cos(math.radians(TILT_DEG))
    dirs = np.array([[s, -c, 0.0], [-s, -c, 0.0]])  # r = (s, c, 0) and (-s, c, 0)
    origins = -0.6 / c * dirs  # 0.6 above the plane's point at the origin
    out = vs.trace_cone(origins, dirs, np.full(2, TAN_HALF), np.zeros(2), origins, dirs)
    assert vs.meta()["vct"]["glossy_read"] == ("deferred" if deferred else "six faces")
    vs.release()
    env.release()
    assert (out[:, 3] > 0.99).all(), out  # the plane fills the cone
    return out[:, :3].mean(axis=1) / out[:, 3]


def constant_and_k(got: np.ndarray) -> tuple[float, float]:
    """The readings ks (1 + k r_x) at r_x = +sin 40 and -sin 40 as (constant term / ks, k)."""
    return float(got.mean() / KS), float((got[0] - got[1]) / (2.0 * KS * math.sin(math.radians(TILT_DEG))))


#: k of the exact lobe, and the chain's estimate below it (the module's docstring)
K_LOBE = (N_EXP + 1.0) / (N_EXP + 2.0)
K_CHAIN = K_LOBE * (1.0 - 2.0 * math.pi / (N_EXP + 1.0) / 4.0)


@pytest.mark.parametrize("parameterization", ["cube", "dual_paraboloid", "sphere_map"])
def test_a_cone_gathers_the_glossy_reflection_toward_itself(linear_sky, parameterization):
    constant, k = constant_and_k(gathered(linear_sky, parameterization, True))
    assert constant == pytest.approx(1.0, rel=0.01)
    assert K_CHAIN - 0.01 < k < K_LOBE + 0.005, (k, K_CHAIN, K_LOBE)


def test_control_the_six_face_storage_reads_the_stored_direction_both_ways(linear_sky):
    constant, k = constant_and_k(gathered(linear_sky, "cube", False))
    assert constant == pytest.approx(1.0, rel=0.01)  # ks L_g(+y), stored in the +Y face
    assert abs(k) < 0.05
