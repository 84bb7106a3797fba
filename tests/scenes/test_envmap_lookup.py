"""`scenes.environment.envmap.lookup` reproduces Mitsuba's `envmap` emitter (docs/contract.md section 2) to 1e-5."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.environment import envmap
from scenes.environment.directions import direction_to_uv, equirect_directions, uv_to_direction

pytestmark = pytest.mark.mitsuba


def mitsuba_eval(mi, env: np.ndarray, d: np.ndarray, rotation_deg: float) -> np.ndarray:
    import drjit as dr

    emitter = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(env),
                            "to_world": mi.ScalarTransform4f().rotate([0, 1, 0], rotation_deg)})
    si = dr.zeros(mi.SurfaceInteraction3f, len(d))
    si.wi = mi.Vector3f(-d[:, 0], -d[:, 1], -d[:, 2])  # wi points back along the ray
    return np.array(emitter.eval(si)).T


def sample_directions(rng) -> np.ndarray:
    """Random directions at least 1 degree from the poles, plus both sides of the u = 0 seam."""
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d = d[np.abs(d[:, 1]) < np.cos(np.radians(1.0))]
    # the u = 0 seam is the -Z half-plane x = 0; approach it from both sides
    t = rng.uniform(0.05, np.pi - 0.05, 200)
    seam = np.concatenate([np.stack([s * np.sin(t), np.cos(t), -np.sin(t)], -1) for s in (0.0, 1e-6, -1e-6)])
    return np.concatenate([d, seam / np.linalg.norm(seam, axis=1, keepdims=True)])


def random_env(rng) -> np.ndarray:
    # radiance in [0, 1]: tolerances are relative to the map's range. The first and last rows are
    # single directions (the poles), as in any real map.
    # An 8 x 16 map: Mitsuba's float32 col = u W errs by about W * 1.2e-7 pixels, so the bound
    # 1e-5 holds with margin.
    env = rng.random((8, 16, 3)).astype(np.float32)
    env[0], env[-1] = env[0, 0], env[-1, 0]
    return env


@pytest.mark.parametrize("rotation_deg", [0.0, 37.5, -120.0])
def test_lookup_matches_mitsuba(mi, rng, rotation_deg):
    # Mitsuba computes col = u W in float32, which alone moves a value by ~1e-6 of the range
    env = random_env(rng)
    d = sample_directions(rng)
    np.testing.assert_allclose(envmap.lookup(env, d, rotation_deg), mitsuba_eval(mi, env, d, rotation_deg),
                               rtol=0, atol=1e-5)


@pytest.mark.parametrize("rotation_deg", [0.0, 37.5])
def test_lookup_matches_mitsuba_at_the_poles(mi, rng, rotation_deg):
    env = random_env(rng)
    poles = np.array([[0, 1, 0], [0, -1, 0]], dtype=float)
    near = np.array([[1e-4, 1, 0], [0, -1, 1e-4], [0.01, 1, 0.01]], dtype=float)
    near /= np.linalg.norm(near, axis=1, keepdims=True)
    got, want = envmap.lookup(env, poles, rotation_deg), mitsuba_eval(mi, env, poles, rotation_deg)
    # Exactly at a pole, unrotated, both sides compute v = acos(+-1) = 0 or pi exactly.
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-5 if rotation_deg == 0.0 else 2e-3)
    # Near a pole Mitsuba's float32 y is off by up to 6e-8 and acos amplifies that to
    # sqrt(2 * 6e-8) = 3.5e-4 rad = 1e-3 of a row of this map: Mitsuba's own rounding, so the
    # tolerance there is 2e-3 of the range.
    np.testing.assert_allclose(envmap.lookup(env, near, rotation_deg), mitsuba_eval(mi, env, near, rotation_deg),
                               rtol=0, atol=2e-3)


def test_axes_land_on_the_documented_columns():
    # u = 0 is -Z, u = 0.25 is +X, u = 0.5 is +Z, u = 0.75 is -X; v = 0 is +Y
    for d, u in [((0, 0, -1), 0.0), ((1, 0, 0), 0.25), ((0, 0, 1), 0.5), ((-1, 0, 0), 0.75)]:
        uu, vv = direction_to_uv(np.array(d, dtype=float))
        assert uu == pytest.approx(u) and vv == pytest.approx(0.5)
    assert direction_to_uv(np.array([0.0, 1.0, 0.0]))[1] == 0.0


def test_pixel_centres_return_the_pixel_value(rng):
    # equirect_directions(r, c) must look up exactly pixel (r, c): no half-pixel shift, rows align-corners
    env = rng.random((9, 20, 3)).astype(np.float32)
    got = envmap.lookup(env, equirect_directions(9, 20))
    np.testing.assert_allclose(got[1:-1], env[1:-1], atol=2e-6)
    # just off the pole, u = 0.3 falls at col = 0.3 * 20 - 0.5 = 5.5: halfway between columns 5 and 6 of row 0
    near_pole = uv_to_direction(np.array(0.3), np.array(1e-9))
    np.testing.assert_allclose(envmap.lookup(env, near_pole), 0.5 * (env[0, 5] + env[0, 6]), atol=1e-6)
