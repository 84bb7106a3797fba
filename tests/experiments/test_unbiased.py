"""metrics.psnr_unbiased: statistical checks against a known truth (Gaussian reference noise), and the
sampling unit of its standard error (the pixel) by hand, with noise shared by a pixel's channels."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from experiments.measure import metrics

SHAPE = (128, 128, 3)
SEEDS = 50


@pytest.fixture
def truth(rng) -> np.ndarray:
    return rng.uniform(0.2, 0.8, size=SHAPE)


def fixed_error(mse: float) -> np.ndarray:
    """A deterministic error pattern (smooth plus checker) scaled to exactly `mse`."""
    y, x = np.mgrid[0:SHAPE[0], 0:SHAPE[1]]
    e = np.sin(x / 7.0)[..., None] * np.array([1.0, 0.5, -0.8]) + 0.3 * ((x + y) % 2 - 0.5)[..., None]
    return e * math.sqrt(mse / np.mean(e**2))


def noisy(truth: np.ndarray, sigma: float, seed: int) -> np.ndarray:
    return truth + np.random.default_rng(seed).normal(0.0, sigma, truth.shape)


@pytest.mark.parametrize(("mse", "sigma"), [(1e-4, 0.02), (1e-3, 0.01), (2e-5, 0.005)])
def test_mean_recovers_the_psnr_against_the_truth(truth, mse, sigma):
    """Over many seeds psnr_unbiased averages to PSNR(test, truth); psnr is low by 10 log10(1 + s^2 / mse)."""
    test = truth + fixed_error(mse)
    mask = np.ones(SHAPE[:2], bool)
    true_db = metrics.psnr(test, truth, mask)
    assert true_db == pytest.approx(-10 * math.log10(mse), abs=1e-9)
    unbiased, plain = [], []
    for k in range(SEEDS):
        ref, ref2 = noisy(truth, sigma, 2 * k + 1), noisy(truth, sigma, 2 * k + 2)
        value, clamped = metrics.psnr_unbiased(test, ref, ref2, mask)
        assert not clamped
        unbiased.append(value)
        plain.append(metrics.psnr(test, ref, mask))
    predicted_bias = -10 * math.log10(1 + sigma**2 / mse)
    assert np.mean(unbiased) == pytest.approx(true_db, abs=0.2)
    assert np.mean(plain) == pytest.approx(true_db + predicted_bias, abs=0.1)
    assert abs(np.mean(unbiased) - true_db) < abs(np.mean(plain) - true_db) / 2


def test_test_equal_to_the_truth_is_clamped_at_the_resolution(truth):
    """floor = 2 standard errors; for Gaussian noise se = s^2 sqrt(2 / N) over N values."""
    sigma = 0.02
    mask = np.ones(SHAPE[:2], bool)
    resolution_db = -10 * math.log10(metrics.UNBIASED_FLOOR_SE * sigma**2 * math.sqrt(2 / truth.size))
    clamped = []
    for k in range(20):
        value, c = metrics.psnr_unbiased(truth, noisy(truth, sigma, 100 + k), noisy(truth, sigma, 200 + k), mask)
        clamped.append(c)
        assert value == pytest.approx(resolution_db, abs=1.0)  # never above the floor, near it
        assert value <= resolution_db + 0.3
    assert sum(clamped) >= 18  # P(not clamped) = 2.3 % per seed
    assert metrics.psnr_unbiased(truth, noisy(truth, sigma, 1), noisy(truth, sigma, 2), mask).clamped


def test_noise_free_reference_reduces_to_psnr(truth):
    mask = np.ones(SHAPE[:2], bool)
    assert metrics.psnr_unbiased(truth, truth, truth, mask) == (metrics.PSNR_CAP, True)
    test = truth + 0.01
    value, clamped = metrics.psnr_unbiased(test, truth, truth, mask)
    assert not clamped
    assert value == pytest.approx(metrics.psnr(test, truth, mask), abs=1e-9)


def test_empty_mask_gives_none(truth):
    mask = np.zeros(SHAPE[:2], bool)
    assert metrics.psnr_unbiased(truth, truth, truth, mask) == (None, False)


def test_mask_restricts_the_pixels(truth):
    mask = np.zeros(SHAPE[:2], bool)
    mask[20:90, 30:100] = True
    test, ref, ref2 = truth + fixed_error(1e-4), noisy(truth, 0.02, 1), noisy(truth, 0.02, 2)
    before = metrics.psnr_unbiased(test, ref, ref2, mask)
    rng = np.random.default_rng(7)
    for img in (test, ref, ref2):
        img[~mask] = rng.uniform(0, 1, (int((~mask).sum()), 3))
    assert metrics.psnr_unbiased(test, ref, ref2, mask) == before
    ref2[mask] += 0.05  # the masked pixels do count
    assert metrics.psnr_unbiased(test, ref, ref2, mask) != before


def test_finite_and_json_safe_at_the_edges():
    one = np.zeros((1, 1, 3))
    mask = np.ones((1, 1), bool)
    for t, r, r2 in [(one, one, one), (one + 1, one, one), (one, one + 1, one), (one, one, one + 1)]:
        value, clamped = metrics.psnr_unbiased(t, r, r2, mask)
        assert math.isfinite(value) and value <= metrics.PSNR_CAP
        json.dumps(metrics.psnr_unbiased(t, r, r2, mask), allow_nan=False)


# ------------------------------------------------------------------- the pixel is the sampling unit
#
# Reference noise shared by a pixel's three channels (as path-traced noise largely is), in a pattern whose
# statistics are known exactly: with s the noise amplitude, the pixels cycle through (a, b) = (s, s), (s, -s),
# (-s, s), (-s, -s) for r = truth + a, r2 = truth + b (the same a, b on R, G and B), and the test image is
# truth + c. Then d_p = (c - a)^2 - (a - b)^2 / 2 takes the four values c^2 -+ 2 c s +- s^2: its mean is c^2
# (the estimate), its population variance 4 c^2 s^2 + s^4 = V. Over N pixels (ddof 1) the standard error is
#     per pixel:    sqrt(V N / (N - 1)) / sqrt(N) = sqrt(V / (N - 1))
#     per channel:  sqrt(V / (3 N - 1))        (3 N values, each pixel's repeated: the wrong unit)
# and the floor is 2 se. Side 64: N = 4096, s = 0.05.

SIDE, S = 64, 0.05


def shared_channel_noise(truth: np.ndarray, c: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(test, reference, reference2) of the pattern above, over a (SIDE, SIDE, 3) truth."""
    k = np.arange(SIDE * SIDE).reshape(SIDE, SIDE) % 4
    a = np.where(k < 2, S, -S)[..., None]
    b = np.where(k % 2 == 0, S, -S)[..., None]
    return truth + c, truth + a, truth + b


def closed_form(c: float, n_units: int) -> tuple[float, bool]:
    """(value dB, clamped) of the pattern above with `n_units` sampling units (N, or 3 N for channels)."""
    se = math.sqrt((4 * c * c * S * S + S**4) / (n_units - 1))
    floor = metrics.UNBIASED_FLOOR_SE * se
    return -10 * math.log10(max(c * c, floor)), c * c <= floor


@pytest.mark.parametrize(("c", "clamped", "units_differ"), [
    (0.0, True, True),        # the test is the truth: the value is the floor, 2.4 dB lower per pixel
    (0.0077, True, True),     # c^2 = 5.9e-5, between the per-channel floor 4.7e-5 and the per-pixel 8.2e-5
    (0.02, False, False),     # c^2 = 4e-4, well above both floors: a measurement, whatever the unit
])
def test_pixel_is_the_unit_of_the_standard_error_by_hand(c, clamped, units_differ):
    """Noise shared by a pixel's channels: value and clamped flag equal the closed form with N pixels as the
    sampling units (the docstring's se = std(d_p) / sqrt(N)); with 3 N channel values they would differ."""
    truth = np.random.default_rng(3).uniform(0.2, 0.8, (SIDE, SIDE, 3))
    mask = np.ones((SIDE, SIDE), bool)
    n = SIDE * SIDE
    want_value, want_clamped = closed_form(c, n)
    wrong_value, wrong_clamped = closed_form(c, 3 * n)
    assert want_clamped == clamped
    if units_differ:  # the check can tell the channel unit from the pixel unit
        assert abs(wrong_value - want_value) > 1.0 or wrong_clamped != want_clamped
    value, got_clamped = metrics.psnr_unbiased(*shared_channel_noise(truth, c), mask)
    assert got_clamped == want_clamped
    assert value == pytest.approx(want_value, abs=1e-6)


def test_shared_gaussian_noise_gives_the_per_pixel_resolution(truth):
    """Gaussian noise of variance s^2 added alike to a pixel's three channels, test = truth: d_p =
    n1^2 - (n1 - n2)^2 / 2 has variance 2 s^4 (E n^4 = 3 s^4), so se = s^2 sqrt(2 / N) over N pixels and
    the value is -10 log10(2 se) within 0.3 dB, where independent channels (or channel units) give
    s^2 sqrt(2 / (3 N)), 10 log10(sqrt 3) = 2.39 dB higher."""
    sigma = 0.02
    n = SHAPE[0] * SHAPE[1]
    mask = np.ones(SHAPE[:2], bool)
    resolution_db = -10 * math.log10(metrics.UNBIASED_FLOOR_SE * sigma**2 * math.sqrt(2 / n))
    rng = np.random.default_rng(11)
    for _ in range(5):
        n1, n2 = (rng.normal(0.0, sigma, SHAPE[:2])[..., None] for _ in range(2))
        value, _ = metrics.psnr_unbiased(truth, truth + n1, truth + n2, mask)
        assert value == pytest.approx(resolution_db, abs=0.3)
        assert value < resolution_db + 10 * math.log10(math.sqrt(3)) - 1.0


# --------------------------------------------------------------------------- few pixels, the floor, the range, by hand


def _pixels(*rows: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A 1 x N test image of zeros and a noise-free reference (r2 = r) with the given pixels: d_p is the mean
    over channels of r^2, a hand value."""
    r = np.array([rows], np.float64)
    return np.zeros_like(r), r, r.copy(), np.ones(r.shape[:2], bool)


@pytest.mark.parametrize(("rows", "want_db", "want_clamped"), [
    # one pixel, d = 0.25: no spread (se = 0), the floor is the cap's 1e-10: 10 log10(1 / 0.25) = 6.0206 dB
    (((0.5, 0.5, 0.5),), 10 * math.log10(4.0), False),
    # two pixels, d = (0.25, 0.01): est 0.13, std 0.12 sqrt 2, se 0.12, floor 0.24: 10 log10(1 / 0.24), clamped
    (((0.5, 0.5, 0.5), (0.1, 0.1, 0.1)), -10 * math.log10(0.24), True),
    # d = (0.75, 0.25): est 0.5, se 0.25, floor exactly 0.5 = est: clamped (MSE_u <= floor), 10 log10 2
    (((1.0, 1.0, 0.5), (0.5, 0.5, 0.5)), 10 * math.log10(2.0), True),
])
def test_few_pixels_by_hand(rows, want_db, want_clamped):
    """The standard error needs two pixels (one gives se = 0, not a made-up spread), two are enough, and an
    estimate exactly at its floor counts as clamped; values from d_p by hand."""
    value, clamped = metrics.psnr_unbiased(*_pixels(*rows))
    assert value == pytest.approx(want_db, abs=1e-9)
    assert clamped is want_clamped


def test_clamped_at_the_cap_floor():
    """An error below the cap's floor 1e-10 (data_range 1, PSNR_CAP 100 dB) with no spread: t - r = 2^-17 in
    every value, d_p = 2^-34 = 5.8e-11 <= 1e-10, so the value is the cap, 100 dB, and clamped; a floor of
    11^-10 = 3.9e-11 instead would not clamp it."""
    r = np.full((4, 4, 3), 0.5)
    value, clamped = metrics.psnr_unbiased(r + 2.0**-17, r, r.copy(), np.ones((4, 4), bool))
    assert 11.0**-10 < 2.0**-34 <= 1e-10
    assert value == 100.0 and clamped


@pytest.mark.parametrize("scale", [2.0, 255.0])
def test_data_range_scales_out(scale):
    """PSNR is scale-free: images and data_range multiplied by the same factor give the same value (by
    hand, for an error of 0.1 in every value, noise-free reference: 20 dB), and identical images read the
    cap of 100 dB at any range (their floor is data_range^2 1e-10)."""
    r = np.full((4, 4, 3), 0.5)
    mask = np.ones((4, 4), bool)
    value, clamped = metrics.psnr_unbiased(scale * (r + 0.1), scale * r, scale * r, mask, data_range=scale)
    assert value == pytest.approx(20.0, abs=1e-9) and not clamped
    value, clamped = metrics.psnr_unbiased(scale * r, scale * r, scale * r, mask, data_range=scale)
    assert value == pytest.approx(100.0, abs=1e-9) and clamped


def test_single_precision_images_computed_in_double():
    """float32 images (as renders are stored) give the value of the same numbers in float64: differences
    and squares are not rounded to single precision."""
    rng = np.random.default_rng(5)
    t, r, r2 = (rng.uniform(0.2, 0.8, (32, 32, 3)).astype(np.float32) for _ in range(3))
    mask = np.ones((32, 32), bool)
    single = metrics.psnr_unbiased(t, r, r2, mask)
    double = metrics.psnr_unbiased(*(np.asarray(x, np.float64) for x in (t, r, r2)), mask)
    assert single.value == pytest.approx(double.value, rel=1e-13, abs=0)
