"""E8's sharp-shadow part: which packaged probe is broad and which has small bright sources.

A probe's concentration is the smallest solid angle that holds a given fraction of its energy:

    Omega_f = min { sum_{t in S} dOmega_t : sum_{t in S} Y_t dOmega_t >= f sum_t Y_t dOmega_t },

with Y_t the Rec. 709 luminance of texel t and dOmega_t its exact solid angle (the equirect band areas of
`scenes.environment.directions.equirect_solid_angles`). The minimum is reached by taking texels in order of
decreasing radiance Y_t (a fractional knapsack whose value per steradian is Y_t: greedy by Y_t is optimal),
stopping at the first texel that reaches the fraction. A single texel of radiance L and solid angle w in a black map
gives Omega_f = w for every f; a constant map gives Omega_f = 4 pi f (up to one texel).

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
    reached = np.cumsum(energy[order])
    k = int(np.searchsorted(reached, fraction * total * (1.0 - 1e-12)))
    return float(omega[order][: k + 1].sum())


def rank(probes: dict[str, np.ndarray], fraction: float = FRACTION) -> list[tuple[str, float]]:
    """(name, Omega_f) of each probe, the most concentrated first."""
    return sorted(((name, concentration(env, fraction)) for name, env in probes.items()), key=lambda x: x[1])


def pick(probes: dict[str, np.ndarray], fraction: float = FRACTION) -> tuple[str, str]:
    """(broadest, most concentrated) of `probes` by Omega_f."""
    ranked = rank(probes, fraction)
    return ranked[-1][0], ranked[0][0]
