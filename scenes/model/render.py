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
