"""Golden-section search for the minimum of a unimodal function of one variable (Kiefer 1953): the angle
fit (fitting.py) and the display-space exposure fit (display.py)."""

from __future__ import annotations

import math

#: 1 / phi: each step keeps this fraction of the bracket
INV_PHI = (math.sqrt(5.0) - 1.0) / 2.0


def golden_section(f, lo: float, hi: float, tol: float) -> float:
    """The minimum of a unimodal f on [lo, hi], to a bracket narrower than `tol`."""
    a, b = lo, hi
    c, d = b - INV_PHI * (b - a), a + INV_PHI * (b - a)
    fc, fd = f(c), f(d)
    while b - a > tol:
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - INV_PHI * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + INV_PHI * (b - a)
            fd = f(d)
    return 0.5 * (a + b)
