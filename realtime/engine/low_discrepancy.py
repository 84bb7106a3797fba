"""The Hammersley point set every prefilter here samples with, as the engines do (Khronos' hammersley2d,
Filament's, three.js' and Babylon.js' hammersley: the same two coordinates).

    x_i = i / n,  y_i = radical inverse of i in base 2 (van der Corput: the bits of i mirrored about the
    binary point), i = 0 .. n - 1

Computed on the host in float64; the techniques offset x as their estimators need.
"""

from __future__ import annotations

import numpy as np


def radical_inverse_base2(i) -> np.ndarray:
    """Van der Corput's radical inverse in base 2: the 32 low bits of i mirrored about the binary point."""
    i = np.asarray(i, dtype=np.uint64) & np.uint64(0xFFFFFFFF)
    out = np.zeros(i.shape, dtype=np.float64)
    scale = 0.5
    for _ in range(32):
        out += (i & np.uint64(1)).astype(np.float64) * scale
        i = i >> np.uint64(1)
        scale *= 0.5
    return out


def hammersley(n: int) -> tuple[np.ndarray, np.ndarray]:
    """(i / n, radical inverse of i) for i = 0 .. n - 1."""
    i = np.arange(n)
    return i / n, radical_inverse_base2(i)
