"""`Render`: what every renderer returns (docs/contract.md section 6)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Render:
    """A rendered image.

    rgb: (H, W, 3) float32 linear radiance, row 0 at the top.
    mask: (H, W) bool, True where an object covers at least half of the pixel.
    timings: milliseconds by name (e.g. `filter`, `draw`, `total` for the real-time renderer).
    meta: everything else worth reporting (variant, spp, chosen level, cache hit, ...).
    """

    rgb: np.ndarray
    mask: np.ndarray
    timings: dict[str, float] = field(default_factory=dict)
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.rgb.ndim != 3 or self.rgb.shape[2] != 3:
            raise ValueError(f"Render.rgb must be (H, W, 3), got {self.rgb.shape}")
        if self.mask.shape != self.rgb.shape[:2]:
            raise ValueError(f"Render.mask {self.mask.shape} does not match rgb {self.rgb.shape[:2]}")
        if not np.isfinite(self.rgb).all():
            raise FloatingPointError("a renderer produced NaN or Inf radiance")


def pixel_area_means(render: Render, factor: int) -> Render:
    """The image a pixel `factor` times larger would show: each output pixel the mean of a factor x factor
    block of `render`'s pixels (rgb), covered where at least half the block is, as the path tracer's box filter
    and mask take a pixel (groundtruth/pathtracer/reference.py). A real-time image rendered at `factor` times
    the size and reduced so is its pixels' area integral, which a point sample at the pixel's centre is not:
    on a silhouette pixel the centre sample stands for the whole pixel, the path tracer's for the part the
    object covers. Timings and meta are kept, with meta["subpixels"] = factor."""
    h, w = render.mask.shape
    if factor < 1 or h % factor or w % factor:
        raise ValueError(f"pixel_area_means: factor {factor} does not divide the image's {w} x {h} pixels")
    blocks = (h // factor, factor, w // factor, factor)
    rgb = render.rgb.astype(np.float64).reshape(*blocks, 3).mean(axis=(1, 3)).astype(np.float32)
    covered = render.mask.reshape(blocks).mean(axis=(1, 3)) >= 0.5
    return Render(rgb=rgb, mask=covered, timings=dict(render.timings), meta={**render.meta, "subpixels": factor})
