"""The brute-force irradiance cube map (realtime/techniques/irradiance_map/irradiance_convolution.py) against
independent references."""

from __future__ import annotations

import numpy as np
import pytest

import scenes
from groundtruth.exact.quadrature import DIFFUSE_WIDTH, cell_grid, irradiance
from realtime.engine.context import get_context
from realtime.engine.gpu import EnvironmentFilter
from realtime.engine.readback import read_cube_level
from realtime.techniques.irradiance_map.irradiance_convolution import IrradianceConvolver, irradiance_cube_numpy
from scenes.environment import cubemap, environments

pytestmark = pytest.mark.gl


def _filter(env: np.ndarray, base: int) -> EnvironmentFilter:
    f = EnvironmentFilter(get_context(), env, base)
    f.fill_base(0.0)
    f.build_chain()
    return f


@pytest.fixture(scope="module")
def probe():
    env = scenes.load("builtin:sphere-diffuse").environment.radiance()
    f = _filter(env, 64)
    yield env, f
    f.release()


def test_irradiance_of_a_probe_is_the_exact_integral(probe, rng):
    # E from the face-32 level against the quadrature of the equirect map itself; quadrature's
    # `irradiance` is E / pi (the cosine-weighted mean radiance), so E = pi x it.
    env, f = probe
    conv = IrradianceConvolver(get_context(), 16, 32)
    conv.run(f.cube, 1)
    got = conv.read()
    conv.release()
    idx = tuple(rng.integers(0, [6, 16, 16], size=(64, 3)).T)  # random texels: their centres are the normals
    normals = cubemap.texel_directions(16)[idx]
    exact = np.pi * irradiance(cell_grid(env, DIFFUSE_WIDTH), normals)
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got[idx], exact, atol=0.01 * exact.max())


@pytest.mark.parametrize(("size", "source_size"), [(16, 32), (8, 16), (1, 8)])
def test_constant_environment_gives_pi(size, source_size):
    f = _filter(environments.builtin("constant"), 32)
    conv = IrradianceConvolver(get_context(), size, source_size)
    conv.run(f.cube, {32: 0, 16: 1, 8: 2}[source_size])
    np.testing.assert_allclose(conv.read(), np.pi, rtol=1e-4)
    conv.release()
    f.release()


@pytest.mark.parametrize("normalize", [True, False])
@pytest.mark.parametrize(("size", "source_size"), [(16, 16), (4, 16), (2, 8)])
def test_gpu_is_the_numpy_sum_even_opposite_a_1e6_sun(size, source_size, normalize):
    # Every texel to 1e-4 of its own value, including those facing away from a sun 1e6 times the sky
    # (dynamic range of E ~1e5): a shortcut E(-n) = E(n) - n.M would lose them to cancellation.
    env = environments.builtin("sky", {"sun": 1e6, "sun_radius_deg": 5.0})
    f = _filter(env, 32)
    level = {32: 0, 16: 1, 8: 2}[source_size]
    conv = IrradianceConvolver(get_context(), size, source_size, normalize=normalize)
    conv.run(f.cube, level)
    got = conv.read()
    ref = irradiance_cube_numpy(read_cube_level(get_context(), f.cube, level), size, normalize=normalize)
    assert ref.max() / ref.min() > 1e4
    np.testing.assert_allclose(got, ref, rtol=1e-4)
    conv.release()
    f.release()


def test_numpy_reference_is_the_plain_texel_sum():
    # a direct double loop over texels, tiny sizes
    rng = np.random.default_rng(3)
    faces = rng.uniform(0.0, 2.0, size=(6, 4, 4, 3))
    w = cubemap.texel_directions(4).reshape(-1, 3)
    omega = np.tile(cubemap.texel_solid_angles(4).reshape(-1), 6)
    L = faces.reshape(-1, 3)
    n = cubemap.texel_directions(2).reshape(-1, 3)
    plain = np.array([sum(L[k] * max(float(m @ w[k]), 0.0) * omega[k] for k in range(len(w))) for m in n])
    mass = np.array([sum(max(float(m @ w[k]), 0.0) * omega[k] for k in range(len(w))) for m in n])
    np.testing.assert_allclose(irradiance_cube_numpy(faces, 2, normalize=False).reshape(-1, 3), plain, rtol=1e-12)
    np.testing.assert_allclose(irradiance_cube_numpy(faces, 2).reshape(-1, 3), np.pi * plain / mass[:, None],
                               rtol=1e-12)


def test_rejects_a_level_of_another_size(probe):
    _, f = probe
    conv = IrradianceConvolver(get_context(), 8, 32)
    with pytest.raises(ValueError, match="face size 32"):
        conv.run(f.cube, 0)
    conv.release()
