"""metrics.psnr_unbiased: statistical checks against a known truth (Gaussian reference noise)."""

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
