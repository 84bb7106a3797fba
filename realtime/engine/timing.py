"""Frame timing per docs/contract.md section 7: wall time around the work with ctx.finish()."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np


def timed(ctx, work: Callable[[], None]) -> float:
    """Milliseconds of wall time for `work`, finished on the GPU (ctx.finish())."""
    ctx.finish()
    t0 = time.perf_counter()
    work()
    ctx.finish()
    return (time.perf_counter() - t0) * 1e3


def summarize(samples: dict[str, list[float]]) -> dict[str, float]:
    """{name: median} plus {name_p90: 90th percentile} for each series."""
    out = {}
    for name, values in samples.items():
        if values:
            out[name] = float(np.median(values))
            out[f"{name}_p90"] = float(np.percentile(values, 90))
    return out
