"""`iblcheck diagnose`: which convention mistakes explain an engine's image (docs/contract.md section 10).

    diagnose(scene, image, renderer="reference", display=None) -> Diagnosis

Most wrong engine images are one convention off. Each likely mistake is a hypothesis with a forward model
(hypotheses.py: what the engine's image would be if it made the mistake, applied to the reference, with
the re-renders of renders.py), its parameter fitted where it has one (fitting.py), and the mistakes that
explain the image are chosen by greedy forward selection and backward elimination (selection.py) on the
PSNR of display values (scoring.py). A tone-mapped sRGB image (PNG, JPEG) is diagnosed in its own display
space: the predictions go through the operator, exposure and encoding the user names (display.py).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from experiments.measure import metrics
from experiments.measure.diagnosis import fitting, hypotheses
from experiments.measure.diagnosis.display import Display
from experiments.measure.diagnosis.renders import Renders
from experiments.measure.diagnosis.scoring import MIN_GAIN_DB, Scorer, Z
from experiments.measure.diagnosis.selection import Step, select, testable
from experiments.measure.engine_image import read_engine_image

__all__ = ["Diagnosis", "Display", "Step", "diagnose", "read_image"]


def read_image(path: str | Path, scene) -> np.ndarray:
    """An engine's linear image of `scene` (.exr, .pfm, .hdr), checked as `iblcheck compare --image` checks it
    (experiments.measure.engine_image: the size, no NaN or Inf; InputError naming the file), float64."""
    return np.asarray(read_engine_image(path, scene).values, np.float64)


@dataclass(frozen=True)
class Diagnosis:
    """What `diagnose` found: the accepted mistakes (largest gain first) and the PSNR before and after.
    `display`: None for a linear image; for a display image the operator, exposure and bit depth named."""

    scene: str
    mistakes: tuple[Step, ...]
    psnr_before: float
    psnr_after: float
    noise_floor_psnr: float | None
    pixels: int
    tested: tuple[str, ...]
    renderer: str
    seconds: float
    display: Display | None = None

    def to_dict(self) -> dict:
        d = asdict(self)
        d["mistakes"] = [asdict(s) for s in self.mistakes]
        d["tested"] = list(self.tested)
        d["encoding"] = "linear" if self.display is None else "srgb"
        metric = ("psnr of display values over the reference's eroded mask" if self.display is None else
                  "psnr of the image's code values against the predicted ones over the reference's eroded mask")
        d["rule"] = {"metric": metric, "min_gain_db": MIN_GAIN_DB, "standard_errors": Z}
        return d


def diagnose(scene, image: np.ndarray, renderer: str = "reference", display: Display | None = None) -> Diagnosis:
    """The convention mistakes that explain `image` as an engine's render of `scene`, against the reference
    (`renderer`: "reference" = Mitsuba, "quadrature"). `image` (H, W, 3): linear radiance, or with
    `display` (the operator, exposure and bit depth the engine used) the code values in [0, 1] of a
    tone-mapped sRGB image (engine_image.EngineImage.values), diagnosed in display space."""
    t0 = time.perf_counter()
    renders = Renders(scene, renderer)
    base = renders.base()
    mask = metrics.common_mask(base.mask, base.mask)
    scorer = Scorer(scene, image, mask, display)
    names = testable(renders, display is not None)
    mistakes, steps = select(renders, scorer, names)
    before = scorer.psnr(scorer.errors(fitting.predict(renders, {}, scorer)[0]))
    after = scorer.psnr(scorer.errors(fitting.predict(renders, mistakes, scorer)[0]))
    second = renders.second()
    floor = None
    if second is not None:
        pair = fitting.finish(np.asarray(base.rgb, np.float64), {}, scorer)[0], \
            fitting.finish(np.asarray(second.rgb, np.float64), {}, scorer)[0]
        floor = metrics.noise_floor_psnr(scorer.to_display(pair[0]), scorer.to_display(pair[1]), mask & second.mask)
    return Diagnosis(scene=scene.name, mistakes=tuple(steps), psnr_before=before, psnr_after=after,
                     noise_floor_psnr=floor, pixels=int(mask.sum()), tested=tuple(names), renderer=renderer,
                     seconds=time.perf_counter() - t0, display=display)


# the names of every mistake, for the command's help and the docs
NAMES = hypotheses.NAMES
