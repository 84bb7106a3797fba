"""E8's sharp-shadow part: the pure readings of its rows (no rendering, no files).

- `family` / `label`: which technique a row's `techniques` describe (the paper, SH PRT of some order, wavelet PRT of
  some cube size and K terms, the light array with shadow maps).
- `saturation`: the K at which wavelet PRT stops gaining: the smallest K whose unbiased PSNR is within `tol_db`
  (0.5 dB) of the best K at that cube size (the best by PSNR, so a noisy curve that dips is read at its top).
- `criterion`: "wavelet PRT at some K beats the best SH order by at least 6 dB at a frame time within 2x of SH
  PRT's": the best SH row (highest unbiased PSNR over the orders), the wavelet rows whose frame ms is at most twice
  that row's, the best of those; it holds when that one is at least 6 dB above the best SH row.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from experiments.paper.e08_overrides import lights_label

MARGIN_DB = 6.0  # the gain wavelet PRT must show over the best SH order
TIME_FACTOR = 2.0  # ... at a frame time at most this multiple of that SH row's
SATURATION_DB = 0.5  # a K within this of the best K at its cube size has saturated

PAPER, SH, WAVELET, LIGHTS = "paper (no occlusion)", "SH PRT", "wavelet PRT", "light array + shadow maps"


@dataclass(frozen=True)
class Point:
    """One row as the criterion reads it."""
    label: str
    db: float | None  # unbiased PSNR
    ms: float | None  # frame time


@dataclass(frozen=True)
class Verdict:
    best_sh: Point | None
    wavelet: Point | None  # the best wavelet row within the time budget (None: none is)
    gain_db: float | None  # wavelet.db - best_sh.db
    time_ratio: float | None  # wavelet.ms / best_sh.ms
    holds: bool
    why: str


def family(t: dict) -> str:
    """The family of a row's `techniques` (realtime.engine.technique.describe)."""
    if t.get("diffuse") == "prt":
        return SH
    if t.get("diffuse") == "wavelet_prt":
        return f"{WAVELET}, cube {t.get('wavelet_prt', {}).get('cube_size')}"
    if "lights" in (t.get("diffuse"), t.get("glossy")):
        return LIGHTS if t.get("occlusion") == "shadow_maps" else "light array"
    return PAPER


def label(t: dict) -> str:
    """A row's technique and its main parameters."""
    if t.get("diffuse") == "prt":
        p = t.get("prt", {})
        return f"SH PRT order {p.get('order')} ({p.get('rays', 0)} rays, {p.get('bounces', 0)} bounces)"
    if t.get("diffuse") == "wavelet_prt":
        w = t.get("wavelet_prt", {})
        return f"wavelet PRT cube {w.get('cube_size')}, K = {w.get('terms')} ({w.get('bounces', 0)} bounces)"
    return lights_label(t) or PAPER


def saturation(points: Sequence[tuple[int, float | None]], tol_db: float = SATURATION_DB) -> int | None:
    """The smallest K of (K, unbiased PSNR) whose PSNR is within `tol_db` of the best; None without a PSNR."""
    known = [(k, db) for k, db in points if db is not None]
    if not known:
        return None
    top = max(db for _, db in known)
    return min(k for k, db in known if db >= top - tol_db)


def criterion(sh: Sequence[Point], wavelet: Sequence[Point], margin_db: float = MARGIN_DB,
              time_factor: float = TIME_FACTOR) -> Verdict:
    """The 6 dB / 2x criterion (module docstring) on the SH rows and the wavelet rows of one scene and probe."""
    sh_ok = [p for p in sh if p.db is not None and p.ms]
    if not sh_ok:
        return Verdict(None, None, None, None, False, "no measured SH PRT row")
    best_sh = max(sh_ok, key=lambda p: p.db)
    wav_ok = [p for p in wavelet if p.db is not None and p.ms]
    if not wav_ok:
        return Verdict(best_sh, None, None, None, False, "no measured wavelet PRT row")
    budget = time_factor * best_sh.ms
    within = [p for p in wav_ok if p.ms <= budget]
    if not within:
        fastest = min(wav_ok, key=lambda p: p.ms)
        return Verdict(best_sh, None, None, fastest.ms / best_sh.ms, False,
                       f"no wavelet row within {time_factor:g}x of {best_sh.ms:.2f} ms (the fastest, "
                       f"{fastest.label}, takes {fastest.ms:.2f} ms)")
    w = max(within, key=lambda p: p.db)
    gain, ratio = w.db - best_sh.db, w.ms / best_sh.ms
    holds = gain >= margin_db
    why = (f"{w.label} is {gain:+.2f} dB from {best_sh.label} at {ratio:.2f}x its frame time "
           f"({'at least' if holds else 'less than'} {margin_db:g} dB)")
    return Verdict(best_sh, w, gain, ratio, holds, why)
