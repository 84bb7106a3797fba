"""scenes.environment.shbasis.sh_basis: the orders it takes, against the constants of docs/contract.md section 3 (eq.
8)."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.environment import shbasis


def test_order_zero_is_the_constant_and_order_two_is_eq_8():
    d = np.array([[0.6, 0.0, 0.8], [0.0, 1.0, 0.0], [-0.48, 0.6, 0.64]])
    np.testing.assert_array_equal(shbasis.sh_basis(d, 0), np.full((3, 1), 0.282095))
    x, y, z = d.T
    eq8 = np.stack([np.full(3, 0.282095), 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y,
                    1.092548 * y * z, 0.315392 * (3 * z * z - 1), 1.092548 * x * z, 0.546274 * (x * x - y * y)], -1)
    np.testing.assert_allclose(shbasis.sh_basis(d, 2), eq8, rtol=1e-12)


@pytest.mark.parametrize("order", [-1, 9])
def test_orders_outside_0_to_8_are_refused(order):
    with pytest.raises(ValueError, match=f"SH order must be 0..8, got {order}"):
        shbasis.sh_basis(np.array([[0.0, 0.0, 1.0]]), order)
