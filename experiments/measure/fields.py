"""What a number read back from a file iblcheck trusts may be: the one check of its meaning.

iblcheck reads its own files back — gate baselines (experiments/runs/gate.py), results.jsonl rows
(experiments/measure/results.py), the measured arrays kept beside a row (experiments/publish/images.py)
— and acts on their numbers: a baseline's `mse_se` sets the gate's tolerance, a row's PSNR goes into
the paper's tables. A file edited by hand, written by another tool or corrupted can hold a number of
the right type and no meaning (a standard error of -1 widens the PSNR tolerance from 0.29 dB to 24.6 dB,
so a regression passes). Every such number is checked here against what it measures:

    problem(name, value) -> str | None       # what is wrong with one value of the field `name`
    check(mapping, names, where, error)      # the first problem of several fields, raised as `error`

`MEANINGS` holds the fields by name; a name means the same in every file (a baseline's `psnr` and a
row's `psnr` are the same measurement, metrics.psnr). The ranges follow from the definitions in
experiments/measure/metrics.py: display values lie in [0, 1], so an MSE is at most 1 and a PSNR lies in
[0, metrics.PSNR_CAP]; SSIM lies in [-1, 1]; FLIP in [0, 1]; standard errors, relative MSEs and times
are finite and >= 0; pixel counts, image sizes and sample counts are integers >= 1 where the value
counts something (a row without metrics may count 0 pixels: see `check_pixels`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from experiments.measure.metrics import PSNR_CAP


@dataclass(frozen=True)
class Meaning:
    """The values a field may hold: a finite number (an int when `integer`) in [low, high], or null
    when `nullable`. `what` names the quantity in the error message."""

    what: str
    low: float | None = None
    high: float | None = None
    integer: bool = False
    nullable: bool = True

    def problem(self, value: Any) -> str | None:
        if value is None:
            return None if self.nullable else f"null where {self.what} is required"
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or (self.integer and not isinstance(value, int)):
            return f"{_show(value)} is not {self.what}"
        if not math.isfinite(value):
            return f"{_show(value)} is not {self.what} (not finite)"
        if (self.low is not None and value < self.low) or (self.high is not None and value > self.high):
            return f"{_show(value)} is not {self.what} ({self.range()})"
        return None

    def range(self) -> str:
        if self.high is None:
            return f">= {self.low:g} required"
        if self.low is None:
            return f"<= {self.high:g} required"
        return f"{self.low:g} to {self.high:g} required"


_PSNR = Meaning("a PSNR in dB", 0.0, PSNR_CAP)
_SE = Meaning("a standard error", 0.0)
_TIME = Meaning("a time", 0.0)
_COUNT = Meaning("a positive count", 1, integer=True)

#: every field of iblcheck's own files whose number has a meaning to check, by name
MEANINGS: dict[str, Meaning] = {
    "psnr": _PSNR, "psnr_unbiased": _PSNR, "noise_floor_psnr": _PSNR,
    "ssim": Meaning("an SSIM", -1.0, 1.0), "flip": Meaning("a FLIP error", 0.0, 1.0),
    "rel_mse": Meaning("a relative MSE", 0.0),
    "mse_se": _SE, "ssim_se": _SE, "flip_se": _SE,
    # how a metric moves per unit of reference noise variance (measured; either sign)
    "ssim_noise_slope": Meaning("a slope"), "flip_noise_slope": Meaning("a slope"),
    "pixels": Meaning("a count of pixels", 0, integer=True, nullable=False),
    "width": _COUNT, "height": _COUNT, "reference_spp": _COUNT,
    "face_size": Meaning("a face size", 0, integer=True),  # 0 in a row whose render never ran
    "reference_s": _TIME, "equal_quality_s": _TIME, "total": _TIME,
}


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _at(where: str, name: str) -> str:
    return f"{where}.{name}" if where else name


def problem(name: str, value: Any) -> str | None:
    """What is wrong with `value` as the field `name` (None when it is right or `name` is unknown)."""
    meaning = MEANINGS.get(name)
    return None if meaning is None else meaning.problem(value)


def check(mapping: Mapping[str, Any], names: Iterable[str], where: str, error: type[Exception] = ValueError) -> None:
    """Raise `error("{where}.{name}: {problem}")` for the first of `names` whose value in `mapping`
    (missing counts as null) has no meaning."""
    for name in names:
        why = problem(name, mapping.get(name))
        if why:
            raise error(f"{_at(where, name)}: {why}")


def check_timings(timings: Any, where: str, error: type[Exception] = ValueError) -> None:
    """A dict of times in ms (a row's `realtime_ms`): every value null or a finite time >= 0."""
    if not isinstance(timings, Mapping):
        raise error(f"{where}: must be an object of times")
    for key, value in timings.items():
        why = _TIME.problem(value)
        if why:
            raise error(f"{_at(where, key)}: {why}")


def check_pixels(mapping: Mapping[str, Any], where: str, error: type[Exception] = ValueError) -> None:
    """`pixels` as a count, and >= 1 when the metrics beside it are numbers (a PSNR of no pixels has
    no meaning; metrics of an empty comparison are null)."""
    check(mapping, ["pixels"], where, error)
    measured = [k for k in ("psnr", "ssim", "flip") if mapping.get(k) is not None]
    if measured and mapping["pixels"] < 1:
        raise error(f"{_at(where, 'pixels')}: 0 pixels beside a {measured[0]} (a metric needs pixels to count)")
