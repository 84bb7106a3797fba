"""Real-time image against a reference: the metrics of design.md section 7 and the timings.

    compare(test, reference, scene, reference2=None) -> dict       # the keys of `iblcheck compare`
    run(scene) -> Comparison                                          # renders both, then compares

All image metrics use the common mask (both coverage masks, eroded by 1 pixel) and both images
tone-mapped with the scene's parameters. The noise floor needs a second, independent reference:
pass it as `reference2`, or it is rendered (and cached) with `groundtruth.reference.second_seed`.
A noise-free reference (the quadrature) has the floor `metrics.PSNR_CAP`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.render import Render

from . import metrics

#: a real-time score within this many dB of the noise floor is "at the noise floor"
AT_FLOOR_DB = 1.0


def second_reference(reference: Render, scene) -> Render | None:
    """The other-seed render of a Mitsuba reference (cached); None for a noise-free reference."""
    if reference.meta.get("renderer") != "reference":
        return None
    from groundtruth.reference import render, second_seed

    return render(scene, spp=reference.meta["spp"], seed=second_seed(reference.meta["seed"]))


def compare(test: Render, reference: Render, scene, reference2: Render | None = None) -> dict:
    """Metrics of `test` against `reference` for `scene` (see the module docstring).

    Keys: scene, psnr, ssim, flip, rel_mse, noise_floor_psnr, at_noise_floor, realtime_ms
    (filter, draw, total), reference_s, reference_spp, pixels. A metric with no pixels is None.
    """
    mask = metrics.common_mask(test.mask, reference.mask)
    a, b = metrics.display(scene, test.rgb), metrics.display(scene, reference.rgb)
    if reference2 is None:
        reference2 = second_reference(reference, scene)
    if reference2 is None:
        floor = metrics.PSNR_CAP if mask.any() else None
    else:
        floor = metrics.noise_floor_psnr(b, metrics.display(scene, reference2.rgb), mask & reference2.mask)
    psnr = metrics.psnr(a, b, mask)
    out = {
        "scene": scene.name,
        "psnr": psnr,
        "ssim": metrics.ssim(a, b, mask),
        "flip": metrics.flip(a, b, mask),
        "rel_mse": metrics.rel_mse(test.rgb, reference.rgb, mask),
        "noise_floor_psnr": floor,
        "at_noise_floor": None if psnr is None or floor is None else bool(psnr >= floor - AT_FLOOR_DB),
        "realtime_ms": {k: test.timings.get(k) for k in ("filter", "draw", "total")},
        "reference_s": (reference.timings.get("render") or 0.0) / 1e3,
        "reference_spp": reference.meta.get("spp"),
        "reference_cache": reference.meta.get("cache"),
        "pixels": int(mask.sum()),
    }
    return out


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
    cols = [("scene", "scene", "{}"), ("PSNR dB", "psnr", "{:.2f}"), ("floor dB", "noise_floor_psnr", "{:.2f}"),
            ("SSIM", "ssim", "{:.4f}"), ("FLIP", "flip", "{:.4f}"), ("relMSE", "rel_mse", "{:.3g}"),
            ("filter ms", ("realtime_ms", "filter"), "{:.2f}"), ("draw ms", ("realtime_ms", "draw"), "{:.2f}"),
            ("ref s", "reference_s", "{:.1f}"), ("spp", "reference_spp", "{}"), ("pixels", "pixels", "{}")]

    def get(row, key):
        return row.get(key[0], {}).get(key[1]) if isinstance(key, tuple) else row.get(key)

    cells = [[h for h, _, _ in cols]]
    for row in rows:
        cells.append(["-" if get(row, k) is None else f.format(get(row, k)) for _, k, f in cols])
    widths = [max(len(r[i]) for r in cells) for i in range(len(cols))]
    lines = ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths, strict=True)))
             for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)
