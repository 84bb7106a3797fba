"""The forward model of a display-encoded engine image (PNG, JPEG: a tone-mapped sRGB screenshot).

    Display(tonemap, exposure, bits).encode(rgb, mistakes) -> code values in [0, 1]
    Display.fit_exposure(rgb, mistakes, target, mask) -> the exposure factor that explains the image best

Such an image holds code values, not radiance: what the engine wrote after its operator and the sRGB
encoding. The user names the operator and exposure (`--tonemap`, `--exposure`, the same meaning as for
`iblcheck compare --image`, experiments/measure/engine_image.py), so the diagnosis predicts the file:
the reference under the mistakes, times the exposure factor (the `exposure` mistake's k times the named
exposure, before the operator, as three.js's toneMappingExposure), through the operator (the named one,
or under the `tonemap` mistake another), the sRGB encoding (none under `srgb_not_encoded`, twice under
`srgb_twice`), clipped to [0, 1] and rounded to the image's bit depth. It is compared with the file's
code values, so the score is the PSNR of code values (range 1), the display-space metric of
`iblcheck compare --image`.

The exposure factor k has no closed form through a saturating operator and the rounding: it is the
minimum of the code-value MSE over log k in [log 1/16, log 16], found on a grid of EXPOSURE_GRID steps
(a saturating curve can make the MSE flat far from the minimum) and refined around the grid's best by
golden-section search (Kiefer 1953) to EXPOSURE_TOL in log k.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from experiments.measure.diagnosis.golden import golden_section
from scenes.model import tone_operators
from scenes.model.tonemap import srgb_encode

#: the exposure factor's search range: a factor of 16 either way (4 stops ... the 8 stops of a badly
#: set exposure slider are far outside what any convention mistake makes)
EXPOSURE_RANGE = (1.0 / 16.0, 16.0)
#: the grid's step in log2 k before the golden-section refinement
EXPOSURE_GRID = 0.25
#: golden-section tolerance in ln k (0.1 %)
EXPOSURE_TOL = 1e-3


@dataclass(frozen=True)
class Display:
    """How the engine's display image was made, as the user names it: operator, exposure, bit depth
    (8 or 16; None: not quantised)."""

    tonemap: str
    exposure: float
    bits: int | None

    def encode(self, rgb: np.ndarray, mistakes: dict) -> np.ndarray:
        """The code values (H, W, 3) in [0, 1] an engine making the display-stage `mistakes` writes for the
        radiance `rgb` (module docstring; `mistakes["exposure"]` is the factor k, 1 when absent)."""
        k = float(mistakes.get("exposure") or 1.0)
        x = tone_operators.apply(mistakes.get("tonemap", self.tonemap), rgb, self.exposure * k)
        if "srgb_not_encoded" not in mistakes:
            x = srgb_encode(x)
        if "srgb_twice" in mistakes:
            x = srgb_encode(x)
        x = np.clip(x, 0.0, 1.0)
        if self.bits is None:
            return x
        top = float((1 << self.bits) - 1)
        return np.round(x * top) / top

    def fit_exposure(self, rgb: np.ndarray, mistakes: dict, target: np.ndarray, mask: np.ndarray) -> float:
        """The factor k minimising the code-value MSE of `encode(rgb, mistakes with k)` against `target`
        (the image's code values at `mask`, (N, 3)) over EXPOSURE_RANGE (module docstring)."""
        pixels = np.asarray(rgb, np.float64)[mask]

        def mse(log2k: float) -> float:
            codes = self.encode(pixels, {**mistakes, "exposure": 2.0 ** log2k})
            return float(((codes - target) ** 2).mean())

        lo, hi = math.log2(EXPOSURE_RANGE[0]), math.log2(EXPOSURE_RANGE[1])
        grid = np.arange(lo, hi + EXPOSURE_GRID / 2, EXPOSURE_GRID)
        values = [mse(g) for g in grid]
        best = grid[int(np.argmin(values))]
        a, b = max(lo, best - EXPOSURE_GRID), min(hi, best + EXPOSURE_GRID)
        tol = EXPOSURE_TOL / math.log(2.0)  # ln k tolerance in log2 units
        x = golden_section(mse, a, b, tol)
        # the grid point itself when the search (on a piecewise-constant rounded MSE) ends worse
        return float(2.0 ** (x if mse(x) <= min(values) else best))
