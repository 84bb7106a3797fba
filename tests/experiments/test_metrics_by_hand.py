"""SSIM and FLIP against values computed here from their published definitions, not from the libraries
that experiments.measure.metrics calls.

SSIM (Wang et al. 2004) of two constant images a, b: both variances and the covariance are 0, so the
structure term is C2 / C2 = 1 and SSIM = (2 a b + C1) / (a^2 + b^2 + C1), C1 = (0.01 L)^2, L = 1 (the data
range); the colour SSIM is the mean over the channels.

FLIP (Andersson et al. 2020, LDR) of two constant images: the edge and point features vanish, so the error
is the colour term alone: sRGB -> linear -> XYZ -> CIELAB (white = XYZ of linear (1, 1, 1)), the Hunt
adjustment (a, b scaled by L / 100), the HyAB distance |dL| + ||d(a, b)||, raised to qc = 0.7 and mapped
with pc = 0.4, pt = 0.95 against cmax, the same distance between pure green and pure blue. The spatial
filters are normalised, so they leave a constant image alone. The library agrees to 3e-5 (float32).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from experiments.measure import metrics

# --------------------------------------------------------------------------- SSIM

C1 = (0.01 * 1.0) ** 2


def ssim_constant(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.mean((2 * a * b + C1) / (a * a + b * b + C1)))


def constant(rgb, shape=(40, 50)) -> np.ndarray:
    return np.ascontiguousarray(np.broadcast_to(np.asarray(rgb, np.float64), (*shape, 3)))


@pytest.mark.parametrize(("a", "b"), [((0.5, 0.5, 0.5), (0.6, 0.6, 0.6)), ((0.2, 0.4, 0.6), (0.1, 0.45, 0.9)),
                                      ((0.05, 0.05, 0.05), (0.0, 0.0, 0.0))])
def test_ssim_of_constant_images_by_hand(a, b):
    # e.g. 0.5 vs 0.6: (0.6 + 1e-4) / (0.61 + 1e-4) = 0.98361...; 0.05 vs 0: 1e-4 / (0.0025 + 1e-4) = 0.03846...
    mask = np.ones((40, 50), bool)
    assert metrics.ssim(constant(b), constant(a), mask) == pytest.approx(ssim_constant(a, b), abs=1e-9)


def test_ssim_masked_mean_of_two_regions_by_hand():
    """Left half (a vs b1) and right half (a vs b2): away from their border (3 px, the 7 x 7 window) the
    SSIM map is each pair's constant value, so a mask of 100 left and 200 right pixels averages them 1:2."""
    a, b1, b2 = (0.5, 0.5, 0.5), (0.7, 0.7, 0.7), (0.1, 0.2, 0.1)
    ref = constant(a)
    test = constant(b1)
    test[:, 25:] = b2
    mask = np.zeros((40, 50), bool)
    mask[10:20, 5:15] = True  # 100 pixels, >= 3 px from the image border and from column 25
    mask[10:30, 32:42] = True  # 200 pixels
    expected = (100 * ssim_constant(a, b1) + 200 * ssim_constant(a, b2)) / 300
    assert metrics.ssim(test, ref, mask) == pytest.approx(expected, abs=1e-9)
    # the two values are far apart: averaging the wrong pixels cannot pass
    assert abs(ssim_constant(a, b1) - ssim_constant(a, b2)) > 0.1


def test_ssim_ignores_the_three_pixel_border():
    """scikit-image leaves out a 3-pixel border (half the 7 x 7 window); a mask only there selects nothing."""
    mask = np.zeros((40, 50), bool)
    mask[:3, :] = True
    mask[:, -3:] = True
    assert metrics.ssim(constant((0.6,) * 3), constant((0.5,) * 3), mask) is None


# --------------------------------------------------------------------------- FLIP

SRGB_TO_XYZ = np.array([[0.4124564, 0.3575761, 0.1804375],
                        [0.2126729, 0.7151522, 0.0721750],
                        [0.0193339, 0.1191920, 0.9503041]])
QC, PC, PT = 0.7, 0.4, 0.95


def srgb_to_linear(c) -> np.ndarray:
    c = np.asarray(c, float)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def hunt_lab(linear_rgb) -> np.ndarray:
    white = SRGB_TO_XYZ @ np.ones(3)
    x, y, z = (SRGB_TO_XYZ @ np.asarray(linear_rgb, float)) / white
    d = 6 / 29

    def f(t):
        return np.cbrt(t) if t > d**3 else t / (3 * d * d) + 4 / 29

    L, a, b = 116 * f(y) - 16, 500 * (f(x) - f(y)), 200 * (f(y) - f(z))
    return np.array([L, 0.01 * L * a, 0.01 * L * b])


def hyab(p, q) -> float:
    return float(abs(p[0] - q[0]) + np.hypot(p[1] - q[1], p[2] - q[2]))


def flip_constant(a, b) -> float:
    cmax = hyab(hunt_lab([0.0, 1.0, 0.0]), hunt_lab([0.0, 0.0, 1.0])) ** QC
    e = hyab(hunt_lab(srgb_to_linear(a)), hunt_lab(srgb_to_linear(b))) ** QC
    if e < PC * cmax:
        return e * PT / (PC * cmax)
    return PT + (e - PC * cmax) / (cmax - PC * cmax) * (1 - PT)


@pytest.mark.parametrize(("a", "b", "value"), [
    ((0.5, 0.5, 0.5), (0.6, 0.5, 0.5), 0.24963),   # a small red shift of mid grey
    ((0.5, 0.5, 0.5), (0.52, 0.52, 0.52), 0.09325),  # a 2 % grey step
    ((0.2, 0.4, 0.6), (0.25, 0.35, 0.6), 0.23346),
    ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 0.96738),   # black against white: past pt, below 1
])
def test_flip_of_constant_images_by_hand(a, b, value):
    assert flip_constant(a, b) == pytest.approx(value, abs=1e-5)  # the helper reproduces the numbers written
    mask = np.zeros((40, 50), bool)
    mask[8:30, 10:45] = True
    got = metrics.flip(constant(b).astype(np.float32), constant(a).astype(np.float32), mask)
    assert got == pytest.approx(flip_constant(a, b), abs=1e-4)


def test_flip_clips_display_values_to_the_unit_range():
    """Display values outside [0, 1] count as 0 or 1: (1.5 vs 0.5) scores as (1 vs 0.5), (-0.3 vs 0.5) as
    (0 vs 0.5), by the same hand computation."""
    mask = np.ones((40, 50), bool)
    for out_of_range, clipped in ((1.5, 1.0), (-0.3, 0.0)):
        got = metrics.flip(constant((out_of_range,) * 3).astype(np.float32), constant((0.5,) * 3).astype(np.float32),
                           mask)
        assert got == pytest.approx(flip_constant((0.5,) * 3, (clipped,) * 3), abs=1e-4)
        got = metrics.flip(constant((0.5,) * 3).astype(np.float32), constant((out_of_range,) * 3).astype(np.float32),
                           mask)
        assert got == pytest.approx(flip_constant((clipped,) * 3, (0.5,) * 3), abs=1e-4)


def test_ssim_on_the_smallest_image_the_window_fits():
    """7 x 7 is the smallest image for the 7 x 7 window: defined, one pixel (the centre) left after the
    3-pixel border; 6 x 7 is too small (None)."""
    mask = np.ones((7, 7), bool)
    got = metrics.ssim(constant((0.6,) * 3, (7, 7)), constant((0.5,) * 3, (7, 7)), mask)
    assert got == pytest.approx(ssim_constant((0.5,) * 3, (0.6,) * 3), abs=1e-9)
    assert metrics.ssim(constant((0.6,) * 3, (6, 7)), constant((0.5,) * 3, (6, 7)), np.ones((6, 7), bool)) is None


# --------------------------------------------------------------------------- PSNR and masks


@pytest.mark.parametrize(("data_range", "offset", "value"), [
    (2.0, 0.1, 26.020599913),   # 10 log10(4 / 0.01) = 10 (0.60206 + 2)
    (0.5, 0.1, 13.979400087),   # 10 log10(0.25 / 0.01) = 10 log10 25
])
def test_psnr_with_a_data_range_by_hand(data_range, offset, value):
    img = np.full((8, 8, 3), 0.25)
    assert metrics.psnr(img + offset, img, np.ones((8, 8), bool), data_range=data_range) == pytest.approx(value,
                                                                                                         abs=1e-8)


@pytest.mark.parametrize(("mse", "capped"), [(5e-11, True), (2e-10, False), (1e-9, False)])
def test_psnr_cap_is_at_an_mse_of_1e_minus_10(mse, capped):
    """PSNR_CAP = 100 dB: an MSE at or below 1e-10 (of data_range^2) is reported as 100 dB; 2e-10 is
    10 log10(1 / 2e-10) = 96.99 dB, a real value."""
    img = np.full((4, 4, 3), 0.5)
    got = metrics.psnr(img + math.sqrt(mse), img, np.ones((4, 4), bool))
    assert got == (metrics.PSNR_CAP if capped else pytest.approx(-10 * math.log10(mse), abs=1e-3))


def test_common_mask_erodes_one_pixel_by_default_and_at_the_image_border():
    """The default is docs/contract.md's 1-pixel erosion (a 3 x 3 cross); the image border counts as uncovered, so a
    mask covering the whole 6 x 6 image keeps its 4 x 4 inside; erode = 2 keeps 2 x 2."""
    full = np.ones((6, 6), bool)
    inside = np.zeros((6, 6), bool)
    inside[1:5, 1:5] = True
    np.testing.assert_array_equal(metrics.common_mask(full, full), inside)
    two = np.zeros((6, 6), bool)
    two[2:4, 2:4] = True
    np.testing.assert_array_equal(metrics.common_mask(full, full, erode=2), two)
    # the AND of two masks given as 0/1 numbers
    np.testing.assert_array_equal(metrics.common_mask(full.astype(int), np.zeros((6, 6), int), erode=0),
                                  np.zeros((6, 6), bool))


def test_rel_mse_default_epsilon_by_hand():
    # Rousselle et al.'s eps defaults to 1e-2: (0.6 - 0.5)^2 / (0.5^2 + 0.01) = 0.01 / 0.26
    ref = np.full((2, 2, 3), 0.5)
    assert metrics.rel_mse(ref + 0.1, ref, np.ones((2, 2), bool)) == pytest.approx(0.01 / 0.26, rel=1e-12)
