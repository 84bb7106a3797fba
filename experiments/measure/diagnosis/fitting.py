"""The fitted parameters: the exposure factor, the tone operator and the environment's angle.

    predict(renders, mistakes, scorer) -> (prediction, mistakes with the exposure refitted)
    candidate(name, renders, mistakes, scorer) -> the mistakes with `name` added, its parameter fitted

- exposure: the factor of least squares in linear radiance over the mask (hypotheses.fit_exposure),
  refitted whenever the other mistakes change, since it scales whatever they predict.
- exposure on a display image: a 1-D search through the operator (display.Display.fit_exposure).
- tonemap: each operator of scenes.model.tone_operators.NAMES except "none" (a display image: except the
  one the user named), the best-scoring one.
- env_rotation: the angle in (-180, 180]. Ranked cheaply first: the proxy render (renders.Renders.proxy)
  at every COARSE_STEP_DEG, then, around each of the TOP best coarse angles, a golden-section search on
  the proxy to REFINE_TOL_DEG; each refined angle is then scored with the real reference, and from the
  better one a parabola through the reference's MSE at +-FINAL_STEP_DEG walks to the fit: while its vertex
  lies at the edge of that window (the proxy's few samples can put its minimum degrees off the reference's:
  40 deg read as 36.4 on spheres-pbr-metal), the window moves there, at most MAX_WALK times (rounded to 0.1
  degree, so that the reference renders it needs are cached and reused).
"""

from __future__ import annotations

import math

import numpy as np

from experiments.measure.diagnosis import hypotheses
from experiments.measure.diagnosis.golden import golden_section
from experiments.measure.diagnosis.renders import Renders
from experiments.measure.diagnosis.scoring import Scorer
from scenes.model import tone_operators

COARSE_STEP_DEG = 20.0
TOP = 2
REFINE_TOL_DEG = 0.5
#: the half-width of the parabola fitted on the reference around the proxy's best angle
FINAL_STEP_DEG = 1.0
#: how many windows the final parabola may move across (each one FINAL_STEP_DEG): the proxy's error it corrects
MAX_WALK = 8
#: the golden ratio's conjugate, (sqrt 5 - 1) / 2: golden-section search keeps this fraction per step


def operators(scorer: Scorer) -> tuple[str, ...]:
    """The tone operators a `tonemap` mistake may have applied: on a linear image any but "none"; on a
    display image any other than the one the user named."""
    if scorer.display is not None:
        return tuple(n for n in tone_operators.NAMES if n != scorer.display.tonemap)
    return tuple(n for n in tone_operators.NAMES if n != "none")


def finish(rgb: np.ndarray, mistakes: dict, scorer: Scorer) -> tuple[np.ndarray, dict]:
    """The radiance-, display- and image-stage mistakes applied to a render; returns the prediction and
    `mistakes` with its exposure factor refitted. A linear image: hypotheses' fixed order (tonemap, sRGB,
    flips, the exposure's least squares last). A display image: the flips, then display.Display.encode
    (exposure x the named exposure, the operator, the encoding), the factor by Display.fit_exposure."""
    if scorer.display is not None:
        rgb = hypotheses.flip(rgb, mistakes)
        if "exposure" in mistakes:
            target = scorer.image[scorer.mask]
            mistakes = {**mistakes, "exposure": scorer.display.fit_exposure(rgb, mistakes, target, scorer.mask)}
        return scorer.display.encode(rgb, mistakes), mistakes
    if "tonemap" in mistakes:
        rgb = np.asarray(tone_operators.apply(mistakes["tonemap"], rgb), np.float64)
    if "srgb_encoded" in mistakes:
        rgb = hypotheses.srgb_oetf(rgb)
    rgb = hypotheses.flip(rgb, mistakes)
    if "exposure" in mistakes:
        k = hypotheses.fit_exposure(rgb, scorer.image, scorer.mask)
        rgb = rgb * k
        mistakes = {**mistakes, "exposure": k}
    return rgb, mistakes


def predict(renders: Renders, mistakes: dict, scorer: Scorer) -> tuple[np.ndarray, dict]:
    """The reference as an engine making `mistakes` would have written it (see hypotheses)."""
    return finish(renders.render(mistakes), mistakes, scorer)


def _wrap(angle: float) -> float:
    """The angle in (-180, 180]."""
    a = math.fmod(angle, 360.0)
    a = a - 360.0 if a > 180.0 else a + 360.0 if a <= -180.0 else a
    return 0.0 if a == -0.0 else a


def fit_angle(renders: Renders, mistakes: dict, scorer: Scorer) -> dict:
    """`mistakes` with env_rotation at its best angle (see the module docstring)."""
    base = {k: v for k, v in mistakes.items() if k != "env_rotation"}

    def proxy_mse(angle: float) -> float:
        rgb, _ = finish(renders.proxy(base, angle), base, scorer)
        return float(scorer.errors(rgb).mean())

    coarse = np.arange(0.0, 360.0, COARSE_STEP_DEG)
    values = np.array([proxy_mse(a) for a in coarse])
    # the TOP local minima of the circular coarse curve, best first
    n = len(coarse)
    minima = [i for i in range(n) if values[i] <= values[(i - 1) % n] and values[i] <= values[(i + 1) % n]]
    minima = sorted(minima, key=lambda i: values[i])[:TOP]
    refined = [golden_section(proxy_mse, coarse[i] - COARSE_STEP_DEG, coarse[i] + COARSE_STEP_DEG, REFINE_TOL_DEG)
               for i in minima]

    def mse(angle: float) -> float:
        trial = {**base, "env_rotation": _wrap(round(angle, 1))}
        return float(scorer.errors(predict(renders, trial, scorer)[0]).mean())

    scored = sorted((mse(a), a) for a in refined)
    angle = parabola_walk(mse, scored[0][1], FINAL_STEP_DEG, MAX_WALK)
    return {**base, "env_rotation": _wrap(round(angle, 1))}


def parabola_walk(f, x: float, h: float, max_moves: int) -> float:
    """The vertex of the parabola through f at x - h, x, x + h; while it is clipped to that window's edge
    (the minimum lies beyond it), the window moves to the edge and the parabola is fitted again, at most
    `max_moves` times."""
    for _ in range(max_moves):
        vertex = _parabola_vertex(f, x, h)
        if abs(vertex - x) < h:
            return vertex
        x = vertex
    return _parabola_vertex(f, x, h)


def _parabola_vertex(f, x: float, h: float) -> float:
    """The vertex of the parabola through f at x - h, x, x + h, kept within [x - h, x + h] (x itself when
    the three points are not convex): the last refinement, on the reference."""
    f0, f1, f2 = f(x - h), f(x), f(x + h)
    curvature = f0 - 2.0 * f1 + f2
    if curvature <= 0:
        return x if f1 <= min(f0, f2) else (x - h if f0 < f2 else x + h)
    return x + float(np.clip(0.5 * h * (f0 - f2) / curvature, -h, h))



def candidate(name: str, renders: Renders, mistakes: dict, scorer: Scorer) -> dict:
    """`mistakes` with `name` added and its parameter fitted (the others' kept; exposure refitted)."""
    if name == "env_rotation":
        return fit_angle(renders, mistakes, scorer)
    if name == "tonemap":
        trials = [{**mistakes, "tonemap": op} for op in operators(scorer)]
        scored = [(float(scorer.errors(predict(renders, t, scorer)[0]).mean()), i) for i, t in enumerate(trials)]
        return trials[min(scored)[1]]
    if name == "exposure":
        return {**mistakes, "exposure": 1.0}  # fitted in finish
    return {**mistakes, name: None}
