"""Real-time image against a reference: the metrics of docs/contract.md section 7 and the timings.

    compare(test, reference, scene, reference2=None) -> dict           # the keys of `iblcheck compare`
    compare_renders(test, reference, scene, reference2=None) -> Comparison   # the dict and the Measurement
    run(scene) -> Comparison                                              # renders both, then compares
    render_realtime(scene) -> Render     # realtime.render, its missing-effects warning left to the comparison

Every number comes from one `experiments.measure.pair.measure_pair` of the pair (the display
transform, the masks, PSNR, psnr_unbiased, SSIM and FLIP with their maps, each once).

All image metrics use the common mask (both coverage masks, eroded by 1 pixel) and both images
tone-mapped with the scene's parameters. The noise floor needs a second, independent reference:
pass it as `reference2`, or it is rendered (and cached) with `groundtruth.pathtracer.reference.second_seed`.
A noise-free reference (the quadrature) has the floor `metrics.PSNR_CAP`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

import groundtruth
import realtime
from engines import command as engine_command
from experiments.measure.pair import CLIPPED_SHARE, Measurement, measure_pair
from groundtruth.pathtracer import reference as pathtracer
from realtime.engine.technique import UnsimulatedEffectWarning
from scenes.model.render import Render

#: a real-time score within this many dB of the noise floor is "at the noise floor"
AT_FLOOR_DB = 1.0


def render_realtime(scene) -> Render:
    """The image under test: realtime.render(scene), or the external engine's (engines.command.render) when
    `realtime.renderer = "command"`. The real-time renderer's own warning ("the scene calls for X, which the
    chosen real-time techniques do not simulate") is held back, because measure_pair says what the two
    compared images miss (pair.effects_compared), which depends on the reference too."""
    if scene.realtime.renderer == "command":
        return engine_command.render(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnsimulatedEffectWarning)
        return realtime.render(scene)


def second_reference(reference: Render, scene) -> Render | None:
    """The other-seed render of a Mitsuba reference (cached); None for a noise-free reference."""
    if reference.meta.get("renderer") != "reference":
        return None
    return pathtracer.render(scene, spp=reference.meta["spp"], seed=pathtracer.second_seed(reference.meta["seed"]))


def compare(test: Render, reference: Render, scene, reference2: Render | None = None, *,
            measured: Measurement | None = None) -> dict:
    """Metrics of `test` against `reference` for `scene` (see the module docstring).

    Keys: scene, psnr, psnr_unbiased (with psnr_unbiased_clamped), ssim, flip, rel_mse,
    noise_floor_psnr, at_noise_floor, realtime_ms (filter, draw, total and every other per-frame
    key of the techniques, plus precompute), reference_s, reference_spp, pixels,
    unsimulated_effects; no_signal, why, for an empty comparison only (`pair.Measurement.empty`: too few
    covered pixels, a black or a clipped-white reference); clipped_share, for a comparison more than
    `pair.CLIPPED_SHARE` of whose pixels are white in the reference only. A metric with no pixels is None.

    psnr_unbiased subtracts the reference's own noise variance (half the mean squared difference of
    its two seeds) from the MSE (metrics.psnr_unbiased): what a noise-free reference would score.
    With a noise-free reference (the quadrature) it equals psnr.

    `measured`: the pair already measured (`measure_pair(test, reference, scene,
    second_reference=reference2)`), whose numbers are reported as they are; measured here when None.
    """
    if measured is None:
        if reference2 is None:
            reference2 = second_reference(reference, scene)
        measured = measure_pair(test, reference, scene, second_reference=reference2)
    m = measured
    return {
        "scene": scene.name,
        "psnr": m.psnr,
        "psnr_unbiased": m.psnr_unbiased.value,
        "psnr_unbiased_clamped": m.psnr_unbiased.clamped,
        "ssim": m.ssim,
        "flip": m.flip,
        "rel_mse": m.rel_mse,
        "noise_floor_psnr": m.noise_floor_psnr,
        "at_noise_floor": None if m.psnr is None or m.noise_floor_psnr is None
        else bool(m.psnr >= m.noise_floor_psnr - AT_FLOOR_DB),
        "realtime_ms": realtime_ms(test.timings),
        "reference_s": (reference.timings.get("render") or 0.0) / 1e3,
        "reference_spp": reference.meta.get("spp"),
        "reference_cache": reference.meta.get("cache"),
        "pixels": m.pixels,
        "unsimulated_effects": list(test.meta.get("unsimulated_effects", [])),
        # only for an empty comparison (metrics.no_signal): why its metrics are None (the gate fails it)
        **({"no_signal": m.empty} if m.empty else {}),
        # only where the tone mapping clips most of the reference white (pair.CLIPPED_SHARE; the gate fails it)
        **({"clipped_share": m.clipped} if m.clipped is not None and m.clipped > CLIPPED_SHARE else {}),
    }


def realtime_ms(timings: dict) -> dict:
    """The medians of a real-time render's timings: filter, draw, total, the techniques' own
    per-frame keys and precompute (p90 values and the background are left out)."""
    keys = ["filter", "draw", "total"]
    keys += sorted(k for k in timings if not k.endswith("_p90") and k not in keys and k != "background")
    return {k: timings.get(k) for k in keys}


@dataclass
class Comparison:
    """A real-time render compared with its reference: `compare`'s dict and the measurement behind it."""

    metrics: dict
    test: Render
    reference: Render
    measured: Measurement

    @property
    def mask(self) -> np.ndarray:
        """The common mask of the metrics."""
        return self.measured.mask


def compare_renders(test: Render, reference: Render, scene, reference2: Render | None = None) -> Comparison:
    """`compare` of renders made elsewhere, keeping the measurement (images, masks, maps) for the row.
    `reference2`: the noise-floor reference; rendered (cached) here when None and the reference is Mitsuba's."""
    if reference2 is None:
        reference2 = second_reference(reference, scene)
    measured = measure_pair(test, reference, scene, second_reference=reference2)
    return Comparison(compare(test, reference, scene, reference2, measured=measured), test, reference, measured)


def run(scene, reference: Render | None = None, reference2: Render | None = None) -> Comparison:
    """Render `scene` in real time and (unless given) its cached Mitsuba reference, then compare.
    `reference2`: the noise-floor reference, rendered (cached) here when None."""
    if reference is None:
        reference = groundtruth.render(scene)
    return compare_renders(render_realtime(scene), reference, scene, reference2)
