"""E8's sharp-shadow part: which packaged probe is broad and which has small bright sources.

A probe's concentration is the smallest solid angle that holds a given fraction of its energy, the map read as
the piecewise-constant function it is (texel t: luminance Y_t, Rec. 709, over its exact solid angle dOmega_t, the
equirect band areas of `scenes.environment.directions.equirect_solid_angles`):

    Omega_f = min { sum_t x_t dOmega_t : sum_t x_t Y_t dOmega_t >= f sum_t Y_t dOmega_t, 0 <= x_t <= 1 },

x_t the part of texel t taken. By the bathtub principle (Lieb & Loss, "Analysis", theorem 1.14) the minimum is a
superlevel set: the texels in order of decreasing Y_t, whole until the fraction is nearly reached, then the part
of the next one that reaches it (the greedy solution of this fractional knapsack). A single texel of solid angle w
in a black map gives Omega_f = f w; a constant map gives Omega_f = 4 pi f.

The probe of the smallest Omega_{1/2} has the most energy in the smallest solid angle (sharp shadows); the one of
the largest is the broadest.
"""

from __future__ import annotations

import numpy as np

from scenes.environment import directions

#: The fraction of the energy whose solid angle ranks the probes (half: the sources that cast the shadows).
FRACTION = 0.5


def concentration(env: np.ndarray, fraction: float = FRACTION) -> float:
    """Omega_f of an equirect (H, W, 3) radiance map, in steradians (module docstring)."""
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"fraction = {fraction!r}: must be in (0, 1]")
    h, w = env.shape[:2]
    y = directions.luminance(np.asarray(env, dtype=np.float64)).ravel()
    omega = directions.equirect_solid_angles(h, w).ravel()
    energy = y * omega
    total = energy.sum()
    if not total > 0.0:
        raise ValueError("the map has no energy: its concentration is undefined")
    order = np.argsort(-y, kind="stable")
    order = order[y[order] > 0.0]  # black texels hold nothing
    target = fraction * total
    reached = np.cumsum(energy[order])
    k = min(int(np.searchsorted(reached, target)), len(order) - 1)  # the texel that reaches the target
    before = reached[k - 1] if k else 0.0
    whole = float(omega[order][:k].sum())
    return whole + float((target - before) / y[order][k])  # the part of texel k: its missing energy / its Y


def rank(probes: dict[str, np.ndarray], fraction: float = FRACTION) -> list[tuple[str, float]]:
    """(name, Omega_f) of each probe, the most concentrated first."""
    return sorted(((name, concentration(env, fraction)) for name, env in probes.items()), key=lambda x: x[1])


def pick(probes: dict[str, np.ndarray], fraction: float = FRACTION) -> tuple[str, str]:
    """(broadest, most concentrated) of `probes` by Omega_f."""
    ranked = rank(probes, fraction)
    return ranked[-1][0], ranked[0][0]
