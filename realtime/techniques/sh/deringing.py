"""Deringing SH irradiance: per-band windows that keep E(n) = n^T M n non-negative (every order).

A bright sun makes the truncated SH series ring: E(n) dips below zero on the far side of the
sphere. Scaling band l by a window sigma_l (Sloan 2017, "Deringing spherical harmonics"; Filament's
cmgen does the same) trades sharpness for positivity:

    hanning(l; w) = (1 + cos(pi l / w)) / 2   for l < w, else 0
    lanczos(l; w) = sinc(l / w) = sin(pi l / w) / (pi l / w)   for l < w, else 0

A larger cutoff w is a weaker window (w -> inf: no change). Windows have one factor per band
l = 0..order; the order follows from the coefficient count (9, 16, 25 -> 2, 3, 4) and order 2 is the
paper's SH9 exactly as before. `realtime.sh_window`:
- "none": sigma = (1, ..., 1);
- "hanning", "lanczos": the window at the fixed cutoff `NAMED_CUTOFF`;
- "auto": no window when E is already non-negative; else the weakest Hanning window (the largest
  w, found by bisection) whose E is non-negative over the sphere. w -> 1 keeps only the constant
  band, which is never negative, so a solution always exists.
The minimum of E over the sphere is taken over `N_SPHERE` Fibonacci directions (E is a polynomial of
degree <= 4 in n: smooth, so the grid minimum is within ~1e-4 (order 2) to ~1e-3 (order 4) of the true
one relative to E's range: the spacing is ~0.025 rad and the curvature grows like l^2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from realtime.engine.sh import irradiance_from_sh
from scenes.environment.shbasis import band_of, order_of

NAMED_CUTOFF = 4.0
N_SPHERE = 20000
BANDS = np.array([0, 1, 1, 1, 2, 2, 2, 2, 2])  # order 2 (kept for callers); any order: band_of(order)


def fibonacci_sphere(n: int) -> np.ndarray:
    """n nearly uniform unit directions (n, 3)."""
    i = np.arange(n) + 0.5
    y = 1.0 - 2.0 * i / n
    r = np.sqrt(np.maximum(0.0, 1.0 - y * y))
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=-1)


def window(kind: str, cutoff: float, order: int = 2) -> np.ndarray:
    """Per-band factors (order + 1,) for l = 0..order."""
    lv = np.arange(order + 1, dtype=np.float64)
    x = lv / cutoff
    if kind == "hanning":
        w = 0.5 * (1.0 + np.cos(np.pi * x))
    elif kind == "lanczos":
        w = np.sinc(x)  # numpy's sinc is sin(pi x) / (pi x)
    else:
        raise ValueError(f"unknown SH window {kind!r}")
    return np.where(lv < cutoff, w, 0.0)


def apply(coeffs: np.ndarray, factors) -> np.ndarray:
    """Coefficients (n, C) with band l scaled by factors[l] (one factor per band of their order)."""
    coeffs = np.asarray(coeffs, dtype=np.float64)
    factors = np.asarray(factors)
    order = order_of(len(coeffs))
    if factors.shape != (order + 1,):
        raise ValueError(f"{len(coeffs)} coefficients (order {order}) need {order + 1} band factors, "
                         f"got shape {factors.shape}")
    return coeffs * factors[band_of(order)][:, None]


def min_irradiance(coeffs: np.ndarray, directions: np.ndarray | None = None) -> float:
    """The smallest E(n) over the sphere and the colour channels."""
    d = fibonacci_sphere(N_SPHERE) if directions is None else directions
    return float(irradiance_from_sh(coeffs, d).min())


@dataclass(frozen=True)
class Choice:
    kind: str  # the window applied: none | hanning | lanczos
    cutoff: float | None
    factors: tuple[float, ...]  # one per band l = 0..order
    min_before: float
    min_after: float


def choose(setting: str, coeffs: np.ndarray, iterations: int = 40) -> Choice:
    """The window for `realtime.sh_window = setting` given SH coefficients (9, 16 or 25, 3)."""
    order = order_of(len(coeffs))
    d = fibonacci_sphere(N_SPHERE)
    before = min_irradiance(coeffs, d)
    if setting == "none" or (setting == "auto" and before >= 0.0):
        return Choice("none", None, (1.0,) * (order + 1), before, before)
    if setting in ("hanning", "lanczos"):
        f = window(setting, NAMED_CUTOFF, order)
        return Choice(setting, NAMED_CUTOFF, tuple(map(float, f)), before, min_irradiance(apply(coeffs, f), d))
    if setting != "auto":
        raise ValueError(f"unknown sh_window {setting!r}")
    lo, hi = 1.0, 1e3  # E(lo) >= 0 always (constant band only); search the largest such cutoff
    if min_irradiance(apply(coeffs, window("hanning", hi, order)), d) >= 0.0:
        lo = hi
    for _ in range(iterations):
        mid = math.sqrt(lo * hi)
        if min_irradiance(apply(coeffs, window("hanning", mid, order)), d) >= 0.0:
            lo = mid
        else:
            hi = mid
    f = window("hanning", lo, order)
    return Choice("hanning", lo, tuple(map(float, f)), before, min_irradiance(apply(coeffs, f), d))
