"""The reference's convergence curve, and the path tracer's time to a given PSNR ("equal quality").

    curve(scene, spps=None, max_spp=None, progress=None) -> list[Rung]   # renders (cached) the ladder
    time_model(curve) -> TimeModel | None                               # seconds = fixed_s + per_spp_s * spp
    equal_quality_s(curve, psnr_db) -> (seconds | None, how)            # time the path tracer needs
    summary(curve) -> dict                                              # JSON (no NaN) of all of it

Each rung of the spp ladder is rendered with two seeds through `groundtruth.pathtracer.reference.render`
(so it is rendered once and then read from the reference cache; on a cache hit the stored render
time, `meta["render_ms"]`, comes back as `timings["render"]`). A rung's quality is its noise
floor, `metrics.noise_floor_psnr` of the two seeds' display images: the PSNR of one render of that
rung against the noise-free truth (docs/contract.md section 7).

Time. A rung's `seconds` is the first seed's render time as measured: Mitsuba's image pass, which
includes building the scene and, on the first render of a process (or of a new kernel), Dr.Jit's
JIT compilation of the kernels. `time_model` separates that fixed part from the cost of sampling
with a robust line fit (Theil-Sen) of seconds against spp; `equal_quality_s` reports the sampling
time alone, `per_spp_s * spp`, as the real-time side reports its frames without shader compilation
and warm-up (docs/contract.md section 7). The fixed part is `TimeModel.fixed_s`.

Monte Carlo law: the error variance of an unbiased estimator falls as 1/spp, so PSNR rises by
10 log10(k) dB for k times the samples (+6.02 dB per 4x); equal_quality_s extrapolates with it
outside the ladder (Veach 1997, "Robust Monte Carlo methods for light transport simulation",
section 2.4; Pharr, Jakob and Humphreys, "Physically Based Rendering", 4th ed., section 2.1.4).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from experiments.measure import metrics
from groundtruth.pathtracer import reference

#: the default spp ladder (x4 per rung: +6.02 dB per rung when the Monte Carlo law holds)
DEFAULT_SPPS = (4, 16, 64, 256, 1024, 4096)
#: dB of PSNR per factor 10 of spp (MSE proportional to 1 / spp)
DB_PER_DECADE = 10.0


@dataclass(frozen=True)
class Rung:
    """One rung of the convergence curve.

    spp: samples per pixel. seconds: the first seed's render time (Render.timings["render"] / 1000,
    as measured when it was rendered, cached or not). psnr_db: the noise floor, the PSNR of this
    rung's render against the truth (None without pixels). pixels: the common mask's size.
    cache: the first seed's cache status ("hit", "miss", ...).
    """

    spp: int
    seconds: float
    psnr_db: float | None
    pixels: int
    cache: str | None = None


@dataclass(frozen=True)
class TimeModel:
    """Render time = fixed_s + per_spp_s * spp (fixed_s: scene build, JIT compilation, film)."""

    per_spp_s: float
    fixed_s: float


def ladder(scene, spps: Sequence[int] | None = None, max_spp: int | None = None) -> list[int]:
    """The spp of the rungs: `spps` (default `DEFAULT_SPPS`) up to `max_spp` (default the scene's reference.spp).

    With the default ladder the cap itself is the top rung, so that rung is the scene's own
    reference (the same cache entries as `iblcheck compare`).
    """
    cap = int(max_spp if max_spp is not None else scene.reference.spp)
    rungs = sorted({int(s) for s in (spps if spps is not None else DEFAULT_SPPS) if 0 < int(s) <= cap})
    if spps is None and cap > 0 and cap not in rungs:
        rungs.append(cap)
    return rungs


def rung(scene, spp: int, seed: int | None = None) -> Rung:
    """Render (or read from the cache) `scene` at `spp` with `seed` and its second seed; measure the floor."""
    seed = int(seed if seed is not None else scene.reference.seed)
    a = reference.render(scene, spp=spp, seed=seed)
    b = reference.render(scene, spp=spp, seed=reference.second_seed(seed))
    mask = metrics.common_mask(a.mask, b.mask)
    floor = metrics.noise_floor_psnr(metrics.display(scene, a.rgb), metrics.display(scene, b.rgb), mask)
    return Rung(spp=int(spp), seconds=float(a.timings.get("render") or 0.0) / 1e3, psnr_db=floor,
                pixels=int(mask.sum()), cache=a.meta.get("cache"))


def curve(scene, spps: Sequence[int] | None = None, max_spp: int | None = None, seed: int | None = None,
          progress: Callable[[], None] | None = None) -> list[Rung]:
    """The convergence curve of `scene`'s reference: one `Rung` per spp of `ladder(scene, spps, max_spp)`.

    `progress()` is called after each rung (len(ladder(...)) calls).
    """
    out = []
    for spp in ladder(scene, spps, max_spp):
        out.append(rung(scene, spp, seed))
        if progress:
            progress()
    return out


def time_model(rungs: Sequence[Rung] | None) -> TimeModel | None:
    """Fit seconds = fixed_s + per_spp_s * spp to the rungs; None without rungs.

    per_spp_s is the Theil-Sen slope (the median of the slopes of all pairs of rungs; Sen 1968,
    "Estimates of the regression coefficient based on Kendall's tau", JASA 63): one rung that paid
    the JIT compilation changes the slopes of its own pairs only, and the median ignores them.
    fixed_s is the median residual, at least 0. With one rung, or a slope that is not positive
    (timing noise of tiny renders), per_spp_s is the largest rung's seconds / spp and fixed_s is 0.
    """
    pts = sorted((r.spp, r.seconds) for r in rungs or () if r.spp > 0 and math.isfinite(r.seconds))
    if not pts:
        return None
    slopes = [(t2 - t1) / (s2 - s1) for i, (s1, t1) in enumerate(pts) for s2, t2 in pts[i + 1:] if s2 != s1]
    slope = float(np.median(slopes)) if slopes else 0.0
    if not slope > 0:
        return TimeModel(per_spp_s=max(pts[-1][1], 0.0) / pts[-1][0], fixed_s=0.0)
    fixed = float(np.median([t - slope * s for s, t in pts]))
    return TimeModel(per_spp_s=slope, fixed_s=max(fixed, 0.0))


def spp_for_psnr(rungs: Sequence[Rung], psnr_db: float) -> tuple[float, str] | None:
    """The spp at which the curve reaches `psnr_db`, and how it was found; None without usable rungs.

    Between rungs: linear in (log spp, dB), on the running maximum of the rungs' dB (a noisy rung
    that scores below a smaller one must not make the curve go back). Outside the ladder: the Monte
    Carlo law from the nearest rung, `DB_PER_DECADE` dB per factor 10; how = "interpolated",
    "extrapolated" (above the last rung) or "extrapolated_below" (below the first).
    """
    pts = sorted((r.spp, r.psnr_db) for r in rungs if r.spp > 0 and r.psnr_db is not None)
    if not pts:
        return None
    spp = [float(s) for s, _ in pts]
    db = np.maximum.accumulate([float(d) for _, d in pts]).tolist()
    if psnr_db < db[0]:
        return spp[0] * 10 ** ((psnr_db - db[0]) / DB_PER_DECADE), "extrapolated_below"
    if psnr_db > db[-1]:
        return spp[-1] * 10 ** ((psnr_db - db[-1]) / DB_PER_DECADE), "extrapolated"
    for i in range(len(pts)):
        if db[i] >= psnr_db:
            if i == 0 or db[i] == db[i - 1]:
                return spp[i], "interpolated"
            f = (psnr_db - db[i - 1]) / (db[i] - db[i - 1])
            return math.exp(math.log(spp[i - 1]) + f * (math.log(spp[i]) - math.log(spp[i - 1]))), "interpolated"
    raise AssertionError("unreachable: psnr_db <= db[-1]")


def equal_quality_s(rungs: Sequence[Rung] | None, psnr_db: float | None) -> tuple[float | None, str]:
    """Seconds the path tracer needs to reach `psnr_db` against the truth, and how it was found.

    The time is `time_model(rungs).per_spp_s * spp_for_psnr(rungs, psnr_db)`: the sampling time
    without the fixed per-render part (JIT compilation, scene build; see the module docstring).
    As time is proportional to spp, this is the interpolation of (log time, dB) between rungs.
    how: "interpolated", "extrapolated" (past the last rung, by the Monte Carlo law),
    "extrapolated_below" (less than the first rung), or, with (None, how), "no_psnr" / "no_curve" /
    "overflow" (a target so far past the curve that the time is not a float).
    """
    if psnr_db is None or not math.isfinite(psnr_db):
        return None, "no_psnr"
    model = time_model(rungs)
    try:
        found = spp_for_psnr(rungs, psnr_db) if rungs else None
    except OverflowError:  # more than 1e308 spp
        return None, "overflow"
    if model is None or found is None:
        return None, "no_curve"
    spp, how = found
    seconds = model.per_spp_s * spp
    return (seconds, how) if math.isfinite(seconds) else (None, "overflow")


def summary(rungs: Sequence[Rung]) -> dict:
    """JSON-ready: {"rungs": [...], "per_spp_s", "fixed_s"} (None where there is no model; never NaN)."""
    model = time_model(rungs)
    return {"rungs": [dataclasses.asdict(r) for r in rungs],
            "per_spp_s": None if model is None else model.per_spp_s,
            "fixed_s": None if model is None else model.fixed_s}
