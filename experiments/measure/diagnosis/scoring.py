"""How well a prediction explains the engine's image, and when a correction's gain counts.

The score is the PSNR of display values (experiments.measure.metrics.display: the scene's tone mapping
and sRGB encoding, the same for every image) over the reference's coverage mask eroded by one pixel
(metrics.common_mask), the metric `iblcheck compare` reports; for a display image (a tone-mapped sRGB
PNG or JPEG) the PSNR of its code values against the predicted ones (display.py), the metric
`iblcheck compare --image` reports for it. Every hypothesis is scored on the same
pixels: a flipped or re-rendered prediction is a whole image (the background is the environment), so
its pixels under the mask are defined whatever the mistake moved there.

A correction from prediction A to prediction B gains 10 log10(MSE_A / MSE_B) dB. It counts when the
gain is at least MIN_GAIN_DB and the MSE drop is resolved by the pixels: per pixel
d_p = e_A(p) - e_B(p) (each the channel mean of the squared display error), mean(d) must exceed Z
standard errors std(d) / sqrt(N). Both the reference's noise and the engine's own error make d noisy,
so a noisier reference needs a larger gain: in dB the threshold is
max(MIN_GAIN_DB, 10 log10(MSE_A / (MSE_A - Z se))).
"""

from __future__ import annotations

import math

import numpy as np

from experiments.measure import metrics
from experiments.measure.diagnosis.display import Display

#: the least gain a correction must bring to be reported
MIN_GAIN_DB = 1.0
#: standard errors of the paired MSE difference a correction must exceed (one-sided, 99.9 % for Gaussian d)
Z = 3.0


class Scorer:
    """The engine's image in display values and the pixels every prediction is scored on.

    A linear image (`display` None) and its predictions (radiance) go through the scene's display
    transform; a display image (`display`: its operator, exposure and bit depth) is its code values, and
    its predictions are code values already (display.Display.encode)."""

    def __init__(self, scene, image: np.ndarray, mask: np.ndarray, display: Display | None = None):
        self.scene = scene
        self.image = np.asarray(image, np.float64)
        self.mask = np.asarray(mask, bool)
        self.display = display
        self.target = self.to_display(self.image)[self.mask]

    def to_display(self, values: np.ndarray) -> np.ndarray:
        """The display values a prediction (or the image) is scored in."""
        if self.display is not None:
            return np.asarray(values, np.float64)
        return np.asarray(metrics.display(self.scene, values), np.float64)

    def errors(self, prediction: np.ndarray) -> np.ndarray:
        """(N,) the squared display error of each masked pixel, mean over channels."""
        p = self.to_display(prediction)[self.mask]
        return ((p - self.target) ** 2).mean(axis=1)

    @staticmethod
    def psnr(errors: np.ndarray) -> float:
        """metrics.psnr of the pixels whose errors these are (display range 1, capped at PSNR_CAP)."""
        mse = float(errors.mean())
        if mse <= 10 ** (-metrics.PSNR_CAP / 10):
            return metrics.PSNR_CAP
        return 10.0 * math.log10(1.0 / mse)

    @staticmethod
    def threshold_db(before: np.ndarray, after: np.ndarray) -> float:
        """The gain from `before` to `after` (per-pixel errors) must reach this many dB to count (inf when
        the MSE is below Z standard errors of the paired difference: no gain can be resolved)."""
        d = before - after
        se = float(d.std(ddof=1) / math.sqrt(d.size)) if d.size > 1 else 0.0
        mse = float(before.mean())
        resolved = mse - Z * se
        significance = math.inf if resolved <= 0 else 10.0 * math.log10(mse / resolved)
        return max(MIN_GAIN_DB, significance)

    def gain_db(self, before: np.ndarray, after: np.ndarray) -> float:
        """PSNR(after) - PSNR(before)."""
        return self.psnr(after) - self.psnr(before)
