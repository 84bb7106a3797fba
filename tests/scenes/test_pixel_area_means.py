"""`pixel_area_means`: a finely rendered image reduced to the pixels the path tracer integrates, checked against
images whose pixel integrals are known exactly (a vertical edge through a block, a constant, a ramp)."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.model.render import Render, pixel_area_means

OBJECT, BACKGROUND = 3.0, 1.0


def edge_render(size: int, edge: float) -> Render:
    """An object covering x < edge (in pixels from the left) in front of a background, sampled at pixel
    centres."""
    covered = np.broadcast_to((np.arange(size) + 0.5) < edge, (size, size))
    rgb = np.where(covered[..., None], OBJECT, BACKGROUND).astype(np.float32) * np.ones(3, np.float32)
    return Render(rgb=rgb, mask=covered.copy())


@pytest.mark.parametrize("edge_subpixels, covered", [(1, False), (2, True), (3, True), (4, True)])
def test_a_pixel_holds_its_covered_area(edge_subpixels, covered):
    """4 x 4 subpixels, the edge after `edge_subpixels` columns: the pixel's radiance is the area-weighted mean
    of object and background, and it is covered from half its area on."""
    fine = edge_render(8, edge_subpixels)
    coarse = pixel_area_means(fine, 4)
    share = edge_subpixels / 4
    assert coarse.rgb[0, 0] == pytest.approx([BACKGROUND + (OBJECT - BACKGROUND) * share] * 3)
    assert coarse.mask[0, 0] == covered
    assert coarse.rgb[0, 1] == pytest.approx([BACKGROUND] * 3) and not coarse.mask[0, 1]


def test_rows_and_columns_keep_their_order_and_the_mean_is_kept():
    """A ramp rising down the rows and across the columns reduces to the ramp of the block centres."""
    y, x = np.mgrid[0:12, 0:6].astype(np.float64)
    rgb = np.stack([y, x, y + 10 * x], -1).astype(np.float32)
    coarse = pixel_area_means(Render(rgb=rgb, mask=np.ones((12, 6), bool)), 3)
    cy, cx = np.mgrid[0:4, 0:2] * 3 + 1.0
    assert coarse.rgb == pytest.approx(np.stack([cy, cx, cy + 10 * cx], -1))
    assert coarse.rgb.mean() == pytest.approx(rgb.mean())
    assert coarse.meta["subpixels"] == 3


@pytest.mark.parametrize("factor", [0, 5])
def test_a_factor_that_does_not_divide_the_image_is_refused(factor):
    with pytest.raises(ValueError, match=f"factor {factor}"):
        pixel_area_means(edge_render(8, 2), factor)
