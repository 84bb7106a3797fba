"""Real-time image against a reference: the metrics of design.md section 7 and the timings.

    compare(test, reference, scene, reference2=None) -> dict       # the keys of `iblcheck compare`
    run(scene) -> Comparison                                          # renders both, then compares

All image metrics use the common mask (both coverage masks, eroded by 1 pixel) and both images
tone-mapped with the scene's parameters. The noise floor needs a second, independent reference:
pass it as `reference2`, or it is rendered (and cached) with `groundtruth.pathtracer.reference.second_seed`.
A noise-free reference (the quadrature) has the floor `metrics.PSNR_CAP`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from experiments.measure import metrics
from experiments.publish.text import one_line
from scenes.model.render import Render

#: a real-time score within this many dB of the noise floor is "at the noise floor"
AT_FLOOR_DB = 1.0


def second_reference(reference: Render, scene) -> Render | None:
    """The other-seed render of a Mitsuba reference (cached); None for a noise-free reference."""
    if reference.meta.get("renderer") != "reference":
        return None
    from groundtruth.pathtracer.reference import render, second_seed

    return render(scene, spp=reference.meta["spp"], seed=second_seed(reference.meta["seed"]))


def compare(test: Render, reference: Render, scene, reference2: Render | None = None) -> dict:
    """Metrics of `test` against `reference` for `scene` (see the module docstring).

    Keys: scene, psnr, psnr_unbiased (with psnr_unbiased_clamped), ssim, flip, rel_mse,
    noise_floor_psnr, at_noise_floor, realtime_ms (filter, draw, total and every other per-frame
    key of the techniques, plus precompute), reference_s, reference_spp, pixels,
    unsimulated_effects. A metric with no pixels is None.

    psnr_unbiased subtracts the reference's own noise variance (half the mean squared difference of
    its two seeds) from the MSE (metrics.psnr_unbiased): what a noise-free reference would score.
    With a noise-free reference (the quadrature) it equals psnr.
    """
    mask = metrics.common_mask(test.mask, reference.mask)
    a, b = metrics.display(scene, test.rgb), metrics.display(scene, reference.rgb)
    if reference2 is None:
        reference2 = second_reference(reference, scene)
    if reference2 is None:
        floor = metrics.PSNR_CAP if mask.any() else None
        unbiased = metrics.psnr_unbiased(a, b, b, mask)
    else:
        b2 = metrics.display(scene, reference2.rgb)
        floor = metrics.noise_floor_psnr(b, b2, mask & reference2.mask)
        unbiased = metrics.psnr_unbiased(a, b, b2, mask & reference2.mask)
    psnr = metrics.psnr(a, b, mask)
    out = {
        "scene": scene.name,
        "psnr": psnr,
        "psnr_unbiased": unbiased.value,
        "psnr_unbiased_clamped": unbiased.clamped,
        "ssim": metrics.ssim(a, b, mask),
        "flip": metrics.flip(a, b, mask),
        "rel_mse": metrics.rel_mse(test.rgb, reference.rgb, mask),
        "noise_floor_psnr": floor,
        "at_noise_floor": None if psnr is None or floor is None else bool(psnr >= floor - AT_FLOOR_DB),
        "realtime_ms": realtime_ms(test.timings),
        "reference_s": (reference.timings.get("render") or 0.0) / 1e3,
        "reference_spp": reference.meta.get("spp"),
        "reference_cache": reference.meta.get("cache"),
        "pixels": int(mask.sum()),
        "unsimulated_effects": list(test.meta.get("unsimulated_effects", [])),
    }
    return out


def realtime_ms(timings: dict) -> dict:
    """The medians of a real-time render's timings: filter, draw, total, the techniques' own
    per-frame keys and precompute (p90 values and the background are left out)."""
    keys = ["filter", "draw", "total"]
    keys += sorted(k for k in timings if not k.endswith("_p90") and k not in keys and k != "background")
    return {k: timings.get(k) for k in keys}


@dataclass
class Comparison:
    metrics: dict
    test: Render
    reference: Render
    mask: np.ndarray


def run(scene, reference: Render | None = None) -> Comparison:
    """Render `scene` in real time and (unless given) its cached Mitsuba reference, then compare."""
    import groundtruth
    import realtime

    if reference is None:
        reference = groundtruth.render(scene)
    test = realtime.render(scene)
    return Comparison(compare(test, reference, scene), test, reference,
                      metrics.common_mask(test.mask, reference.mask))


def format_table(rows: list[dict]) -> str:
    """A plain-text table of comparison rows for humans."""
    cols = [("scene", "scene", "{}"), ("PSNR dB", "psnr", "{:.2f}"), ("unbiased dB", "psnr_unbiased", "{:.2f}"),
            ("floor dB", "noise_floor_psnr", "{:.2f}"),
            ("SSIM", "ssim", "{:.4f}"), ("FLIP", "flip", "{:.4f}"), ("relMSE", "rel_mse", "{:.3g}"),
            ("filter ms", ("realtime_ms", "filter"), "{:.2f}"), ("draw ms", ("realtime_ms", "draw"), "{:.2f}"),
            ("frame ms", ("realtime_ms", "total"), "{:.2f}"),  # every per-frame key (lights, shadow, ...) + draw
            ("ref s", "reference_s", "{:.1f}"), ("spp", "reference_spp", "{}"), ("pixels", "pixels", "{}")]

    def get(row, key):
        return row.get(key[0], {}).get(key[1]) if isinstance(key, tuple) else row.get(key)

    cells = [[h for h, _, _ in cols]]
    for row in rows:
        cells.append(["-" if get(row, k) is None else one_line(f.format(get(row, k)), 80) for _, k, f in cols])
    widths = [max(len(r[i]) for r in cells) for i in range(len(cols))]
    lines = ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths, strict=True)))
             for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)
