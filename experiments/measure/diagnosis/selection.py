"""Which mistakes explain the engine's image: greedy forward selection (and every pair tried from nothing,
so that a single mistake mimicking a pair cannot hide it), then backward elimination.

Forward: starting from no mistake, every mistake not yet accepted is added in turn (its parameter fitted,
fitting.candidate) and scored (scoring.Scorer); the one whose correction raises the PSNR most is accepted
when its gain reaches the threshold (scoring.Scorer.threshold_db: at least MIN_GAIN_DB and resolved by
the pixels' noise). Repeated until no mistake gains. Backward: each accepted mistake is taken out in turn
(the others' parameters kept, the exposure refitted); the one whose removal costs least is dropped when
that cost is below the threshold, until every remaining one costs at least the threshold. A mistake's
reported gain is that cost: the PSNR the final set loses without it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from experiments.measure.diagnosis import fitting, hypotheses
from experiments.measure.diagnosis.renders import Renders
from experiments.measure.diagnosis.scoring import Scorer


@dataclass(frozen=True)
class Step:
    """One accepted mistake: its name, its fitted parameter (angle in degrees, factor, operator or None),
    the PSNR the final set loses without it (dB) and the threshold that loss had to reach."""

    name: str
    parameter: float | str | None
    gain_db: float
    threshold_db: float


def testable(renders: Renders, display: bool = False) -> list[str]:
    """The mistakes that apply to this kind of image (hypotheses.FOR_IMAGE) and change this scene's image:
    fov_horizontal needs a non-square image."""
    c = renders.scene.camera
    names = hypotheses.FOR_IMAGE[hypotheses.DISPLAY if display else hypotheses.LINEAR]
    return [n for n in names if not (n == "fov_horizontal" and c.width == c.height)]


def select(renders: Renders, scorer: Scorer, names: list[str]) -> tuple[dict, list[Step]]:
    """The accepted mistakes ({name: parameter}) and their steps, ordered by gain (largest first)."""

    def errors(m: dict) -> tuple[np.ndarray, dict]:
        pred, fitted = fitting.predict(renders, m, scorer)
        return scorer.errors(pred), fitted

    def forward(mistakes: dict, current: np.ndarray) -> tuple[dict, np.ndarray]:
        while True:
            best = None
            for name in names:
                if name in mistakes or hypotheses.EXCLUDES.get(name) in mistakes:
                    continue
                trial = fitting.candidate(name, renders, mistakes, scorer)
                err, fitted = errors(trial)
                gain, threshold = scorer.gain_db(current, err), scorer.threshold_db(current, err)
                if gain >= threshold and (best is None or gain > best[0]):
                    best = (gain, fitted, err)
            if best is None:
                return mistakes, current
            _, mistakes, current = best

    mistakes, current = forward({}, errors({})[0])
    # Greedy forward selection can be caught by one mistake that mimics a pair better than either half
    # does (sRGB-encoded radiance times 0.6 looks more like AgX than like sRGB or exposure alone), and then
    # never reach the pair. So every pair is also tried from nothing (each half's parameter fitted in
    # turn), and the best one, when it explains the image better than the greedy set by the threshold,
    # is the start of a second forward pass.
    best_pair = None
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if hypotheses.EXCLUDES.get(a) == b or hypotheses.EXCLUDES.get(b) == a:
                continue
            trial = fitting.candidate(b, renders, fitting.candidate(a, renders, {}, scorer), scorer)
            err, fitted = errors(trial)
            if best_pair is None or scorer.gain_db(best_pair[1], err) > 0:
                best_pair = (fitted, err)
    if best_pair is not None and scorer.gain_db(current, best_pair[1]) >= scorer.threshold_db(current, best_pair[1]):
        mistakes, current = forward(*best_pair)

    while mistakes:
        costs = []
        for name in mistakes:
            without, _ = errors({k: v for k, v in mistakes.items() if k != name})
            costs.append((scorer.gain_db(without, current), scorer.threshold_db(without, current), name))
        cost, threshold, name = min(costs)
        if cost >= threshold:
            steps = [Step(n, mistakes[n], c, t) for c, t, n in sorted(costs, reverse=True)]
            return mistakes, steps
        mistakes = {k: v for k, v in mistakes.items() if k != name}
        current, mistakes = errors(mistakes)
    return {}, []
