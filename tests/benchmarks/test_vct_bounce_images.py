"""The measures of benchmarks/vct_bounce_images.py on images whose answers are known by construction."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("vct_bounce_images", ROOT / "benchmarks" / "vct_bounce_images.py")
model = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(model)


def test_share_above_counts_the_pixels_over_the_level_and_drops_negative_noise():
    """Four pixels 3, 1, 1, -1 (a difference's noise) over a level of 2: 3 of the 5 the non-negative pixels
    hold; a pixel outside the mask does not count; control: a level above every pixel holds none."""
    image = np.array([[3.0, 1.0], [1.0, -1.0]])
    mask = np.ones_like(image, bool)
    assert model.share_above(image, mask, 2.0) == pytest.approx(3.0 / 5.0)
    mask[0, 0] = False
    assert model.share_above(image, mask, 2.0) == 0.0
    assert model.share_above(image, np.ones_like(mask), 5.0) == 0.0


def test_the_crop_holds_the_bright_pixels_and_its_margin():
    """Two bright pixels at (10, 20) and (14, 30) in a dim 64 x 64 image: the crop spans them plus the margin."""
    image = np.full((64, 64), 1e-6)  # 0.004 in all: the two hold over 99 %
    image[10, 20] = image[14, 30] = 1.0
    rows, cols = model.crop_box(image, np.ones_like(image, bool), margin=3)
    assert (rows.start, rows.stop, cols.start, cols.stop) == (7, 18, 17, 34)
