"""`iblcheck diagnose`: which convention mistakes explain an engine's image (docs/contract.md section 10).

    diagnose(scene, image, renderer="reference") -> Diagnosis

Most wrong engine images are one convention off. Each likely mistake is a hypothesis with a forward model
(hypotheses.py: what the engine's image would be if it made the mistake, applied to the reference, with
the re-renders of renders.py), its parameter fitted where it has one (fitting.py), and the mistakes that
explain the image are chosen by greedy forward selection and backward elimination (selection.py) on the
PSNR of display values (scoring.py).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from experiments.measure import metrics
from experiments.measure.diagnosis import fitting, hypotheses
from experiments.measure.diagnosis.renders import Renders
from experiments.measure.diagnosis.scoring import MIN_GAIN_DB, Scorer, Z
from experiments.measure.diagnosis.selection import Step, select, testable
from experiments.measure.engine_image import read_engine_image

__all__ = ["Diagnosis", "Step", "diagnose", "read_image"]


def read_image(path: str | Path, scene) -> np.ndarray:
    """An engine's linear image of `scene` (.exr, .pfm, .hdr), checked as `iblcheck compare --image` checks it
    (experiments.measure.engine_image: the size, no NaN or Inf; InputError naming the file), float64."""
    return np.asarray(read_engine_image(path, scene).values, np.float64)


@dataclass(frozen=True)
class Diagnosis:
    """What `diagnose` found: the accepted mistakes (largest gain first) and the PSNR before and after."""

    scene: str
    mistakes: tuple[Step, ...]
    psnr_before: float
    psnr_after: float
    noise_floor_psnr: float | None
    pixels: int
    tested: tuple[str, ...]
    renderer: str
    seconds: float

    def to_dict(self) -> dict:
        d = asdict(self)
        d["mistakes"] = [asdict(s) for s in self.mistakes]
        d["tested"] = list(self.tested)
        d["rule"] = {"metric": "psnr of display values over the reference's eroded mask",
                     "min_gain_db": MIN_GAIN_DB, "standard_errors": Z}
        return d


def diagnose(scene, image: np.ndarray, renderer: str = "reference") -> Diagnosis:
    """The convention mistakes that explain `image` (H, W, 3 linear radiance) as an engine's render of
    `scene`, against the reference (`renderer`: "reference" = Mitsuba, "quadrature")."""
    t0 = time.perf_counter()
    renders = Renders(scene, renderer)
    base = renders.base()
    mask = metrics.common_mask(base.mask, base.mask)
    scorer = Scorer(scene, image, mask)
    names = testable(renders)
    mistakes, steps = select(renders, scorer, image, names)
    before = scorer.psnr(scorer.errors(renders.render({})))
    after = scorer.psnr(scorer.errors(fitting.predict(renders, mistakes, image, mask)[0]))
    second = renders.second()
    floor = None
    if second is not None:
        display = metrics.display(scene, base.rgb), metrics.display(scene, second.rgb)
        floor = metrics.noise_floor_psnr(*display, mask & second.mask)
    return Diagnosis(scene=scene.name, mistakes=tuple(steps), psnr_before=before, psnr_after=after,
                     noise_floor_psnr=floor, pixels=int(mask.sum()), tested=tuple(names), renderer=renderer,
                     seconds=time.perf_counter() - t0)


# the names of every mistake, for the command's help and the docs
NAMES = hypotheses.NAMES
