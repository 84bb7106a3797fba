"""The shared Hammersley set (realtime/engine/low_discrepancy.py) against values written out by hand."""

from __future__ import annotations

import numpy as np
import pytest

from realtime.engine.low_discrepancy import hammersley, radical_inverse_base2


@pytest.mark.parametrize(("i", "expected"), [(0, 0.0), (1, 0.5), (2, 0.25), (3, 0.75), (6, 0.375), (11, 0.8125),
                                             (2**31, 2.0**-32)])
def test_radical_inverse_mirrors_the_bits(i, expected):
    assert radical_inverse_base2(np.array([i]))[0] == expected


def test_the_set_stratifies_both_coordinates():
    """Each coordinate of 16 points has exactly one point in each of 16 equal intervals (a grid would not in y)."""
    x, y = hammersley(16)
    assert np.array_equal(np.sort(np.floor(16 * x)), np.arange(16))
    assert np.array_equal(np.sort(np.floor(16 * y)), np.arange(16))
    assert not np.array_equal(y, x)  # negative control: the second coordinate is not the first
