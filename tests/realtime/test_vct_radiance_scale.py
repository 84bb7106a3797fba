"""The voxels' radiance under a bright environment (vct_math.radiance_scale): the faces are RGBA16F, whose largest
value is 65504, and a 1e6 sun's glossy reflection is far above it.

- numpy, by hand: the scale is 1 up to 2^14 (nothing changes for an ordinary scene) and above it the power of two
  that brings the peak under 2^14; a non-finite peak is refused;
- GL: cone tracing is linear in the environment's radiance, so the light the cones gather around a Phong torus
  (exponent 1000, a sky whose sun is 1e3 times its zenith) times 1000 is what they gather under the same sky
  1000 times brighter (its sun 1e6 times the zenith's radiance), to half float's precision. Control: with the
  scale held at 1, the brighter sky's faces clip at half float's largest value and the gathered light falls
  short of the linear answer. Both with the faces storing the glossy reflection (the six-face storage) and with
  the deferred glossy read (the frame's default), which stores the lobe's weight and evaluates the environment in
  single float at the read; the control needs the stored reflection (the deferred read has nothing to clip).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import scenes
from realtime.engine.context import get_context
from realtime.engine.environment_maps import filled_store
from realtime.techniques.vct import vct_math
from realtime.techniques.vct.vct import VoxelScene


def test_radiance_scale_by_hand():
    assert vct_math.radiance_scale(0.0) == 1.0
    assert vct_math.radiance_scale(16384.0) == 1.0
    assert vct_math.radiance_scale(16385.0) == 0.5  # 2^14 / 2^15
    assert vct_math.radiance_scale(1e6) == 2.0 ** (14 - 20)  # 2^19 < 1e6 <= 2^20
    assert 1e6 * vct_math.radiance_scale(1e6) <= 16384.0 < 2e6 * vct_math.radiance_scale(1e6)
    for bad in (math.inf, math.nan, -1.0):
        with pytest.raises(ValueError, match="peak radiance"):
            vct_math.radiance_scale(bad)


def gathered(ctx, env_scale: float, monkeypatch=None, deferred: bool = False) -> tuple[np.ndarray, float]:
    """The diffuse cones' gathered irradiance at 200 points around a Phong torus (exponent 1000) under the sky
    (sun 1e3) times `env_scale`, 32^3, one cascade; and the voxels' radiance scale."""
    if monkeypatch is not None:
        monkeypatch.setattr(vct_math, "radiance_scale", lambda peak: 1.0)
    scene = scenes.load("builtin:torus-phong").with_overrides({
        "environment.map": "builtin:sky", "environment.params": {"sun": 1e3}, "environment.scale": env_scale})
    objects = [dataclasses.replace(o, material=dataclasses.replace(o.material, exponent=1000.0))
               for o in scene.objects]
    env = filled_store(ctx, scene)
    vs = VoxelScene(ctx, objects, 32, 1, 6, 0.5, env_filter=env, deferred_glossy=deferred)
    vs.update(None, env.sh_buffer)
    rng = np.random.default_rng(7)
    d = rng.normal(size=(200, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    points = 1.3 * d  # around the torus, looking at its centre
    out = vs.probe(points, -d)[:, :3]
    scale = vs.radiance_scale
    vs.release()
    env.release()
    return out, scale


@pytest.mark.gl
@pytest.mark.parametrize("deferred", [False, True], ids=["six-faces", "deferred"])
def test_gathered_light_is_linear_in_a_bright_environment(deferred):
    ctx = get_context()
    dim, s_dim = gathered(ctx, 1.0, deferred=deferred)
    bright, s_bright = gathered(ctx, 1000.0, deferred=deferred)
    assert s_dim == 1.0 and s_bright < 1.0
    lit = dim.max(axis=1) > 1e-3 * dim.max()
    assert lit.sum() > 20  # the probe sees the torus's reflections
    assert np.isfinite(bright).all()
    # fp16: 11 significant bits in each face, a few roundings along a cone
    assert bright[lit] == pytest.approx(1000.0 * dim[lit], rel=5e-3)


@pytest.mark.gl
def test_control_unscaled_faces_clip_under_the_bright_environment(monkeypatch):
    ctx = get_context()
    dim, _ = gathered(ctx, 1.0)
    bright, s_bright = gathered(ctx, 1000.0, monkeypatch)
    assert s_bright == 1.0
    lit = dim.max(axis=1) > 1e-3 * dim.max()
    assert (bright[lit] / (1000.0 * dim[lit])).min() < 0.9  # measured: 0.70 at the worst point
