"""Tiny environment maps are read alike by every renderer, from the smallest size iblcheck accepts up.

Three readers of one map: `scenes.environment.envmap.lookup` (which the quadrature reference and every
numpy conversion use), Mitsuba 3's `envmap` emitter (the path-traced reference), and the real-time
renderer's GPU conversion to a cube map. Each is compared with the others on random maps of 3 to 6 rows
and 1 to 7 columns, at directions all over the sphere; the control is the 2-row map, which Mitsuba reads
differently (the reason iblcheck's minimum is 3 rows) and which is refused with that reason.
"""

from __future__ import annotations

import numpy as np
import pytest

from scenes.environment import cubemap, envmap
from scenes.environment.directions import uv_to_direction
from scenes.storage.errors import EnvMapError

SIZES = [(h, w) for h in range(envmap.MIN_ROWS, 7) for w in (1, 2, 3, 7)]


def random_map(height: int, width: int) -> np.ndarray:
    return np.random.default_rng(height * 100 + width).uniform(0.05, 1.0, (height, width, 3)).astype(np.float32)


def sphere_directions() -> np.ndarray:
    u, v = np.meshgrid(np.linspace(0.005, 0.995, 29), np.linspace(0.005, 0.995, 23))
    return uv_to_direction(u.ravel(), v.ravel())


def mitsuba_eval(env: np.ndarray, d: np.ndarray) -> np.ndarray:
    from groundtruth.pathtracer.variant import mitsuba  # deferred: Mitsuba is heavy and marked below

    mi = mitsuba()
    emitter = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(env)})
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(-d[:, 0], -d[:, 1], -d[:, 2])  # the emitter is seen along -wi
    out = np.array(emitter.eval(si))
    return out.T if out.shape[0] == 3 else out


@pytest.mark.mitsuba
@pytest.mark.parametrize("height, width", SIZES)
def test_mitsuba_reads_tiny_maps_as_the_lookup_does(height, width):
    env = random_map(height, width)
    d = sphere_directions()
    np.testing.assert_allclose(mitsuba_eval(env, d), envmap.lookup(env, d), atol=5e-6)


@pytest.mark.mitsuba
def test_control_mitsuba_reads_a_two_row_map_otherwise():
    env = random_map(2, 4)
    d = sphere_directions()
    assert np.abs(mitsuba_eval(env, d) - envmap.lookup(env, d)).max() > 0.05


@pytest.mark.gl
@pytest.mark.parametrize("height, width", SIZES)
def test_the_gpu_cube_is_the_lookup_of_tiny_maps(height, width):
    from realtime.engine.context import get_context  # deferred: GL tests are marked and may be deselected
    from realtime.engine.gpu import EnvironmentFilter

    env = random_map(height, width)
    f = EnvironmentFilter(get_context(), env, 16)
    try:
        f.fill_base(0.0)
        np.testing.assert_allclose(f.read_level(0), cubemap.from_equirect(env, 16, 0.0), rtol=2e-3, atol=1e-5)
    finally:
        f.release()


@pytest.mark.parametrize("rows", [1, 2])
def test_fewer_rows_are_refused_with_the_reason(rows):
    with pytest.raises(EnvMapError, match=f"at least 3 rows, got {rows} .*Mitsuba"):
        envmap.validate(np.ones((rows, 4, 3), np.float32), "tiny")
