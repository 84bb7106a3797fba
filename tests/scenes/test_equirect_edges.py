"""The equirect map's edges (docs/contract.md section 2): the pole rows, and the solid angles of all pixels."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.environment import envmap
from scenes.environment.directions import equirect_solid_angles


def test_the_poles_read_the_first_and_last_rows():
    # rows are align-corners: v = 0 (+Y) is row 0 exactly, v = 1 (-Y) the last row; constant pole rows
    env = np.zeros((5, 8, 3), np.float32)
    env[0] = [1.0, 2.0, 3.0]
    env[-1] = [4.0, 5.0, 6.0]
    env[1:-1] = 0.5
    got = envmap.lookup(env, np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]))
    np.testing.assert_allclose(got, [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], atol=1e-6)


@pytest.mark.parametrize(("h", "w"), [(2, 1), (5, 8), (64, 128)])
def test_pixel_solid_angles_cover_the_sphere(h, w):
    # the rows' bands [theta - dt/2, theta + dt/2], clipped at the poles, tile the sphere: 4 pi in all,
    # and the two pole rows, half-height bands, hold 2 pi (1 - cos(dt/2)) each, dt = pi / (h - 1)
    omega = equirect_solid_angles(h, w)
    assert omega.sum() == pytest.approx(4 * np.pi, rel=1e-12)
    pole = 2 * np.pi * (1 - np.cos(np.pi / (h - 1) / 2))
    assert omega[0].sum() == pytest.approx(pole, rel=1e-12) and omega[-1].sum() == pytest.approx(pole, rel=1e-12)
