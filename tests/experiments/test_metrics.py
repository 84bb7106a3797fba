"""Metrics against values computed by hand and against scikit-image (docs/contract.md section 7)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from skimage.metrics import structural_similarity

from experiments.measure import metrics
from scenes.model.render import Render


@pytest.fixture
def image(rng) -> np.ndarray:
    return rng.uniform(0.1, 0.8, size=(40, 50, 3))


def test_identical_images_give_the_documented_cap(image):
    mask = np.ones(image.shape[:2], bool)
    assert metrics.psnr(image, image, mask) == metrics.PSNR_CAP
    assert metrics.ssim(image, image, mask) == pytest.approx(1.0)
    assert metrics.flip(image, image, mask) == pytest.approx(0.0, abs=1e-6)
    assert metrics.rel_mse(image, image, mask) == 0.0


@pytest.mark.parametrize("offset", [0.1, 0.01, 0.003])
def test_constant_offset_psnr_by_hand(image, offset):
    """MSE = offset^2 on every pixel: PSNR = 10 log10(1 / offset^2) = -20 log10(offset)."""
    mask = np.ones(image.shape[:2], bool)
    assert metrics.psnr(image + offset, image, mask) == pytest.approx(-20 * math.log10(offset), abs=1e-9)


def test_mask_selects_pixels(image):
    mask = np.zeros(image.shape[:2], bool)
    mask[10:20, 10:30] = True
    other = image.copy()
    other[~mask] += 0.5  # differences outside the mask do not count
    assert metrics.psnr(other, image, mask) == metrics.PSNR_CAP
    other[mask] += 0.1
    assert metrics.psnr(other, image, mask) == pytest.approx(20.0, abs=1e-9)


def test_empty_mask_gives_none_everywhere(image):
    mask = np.zeros(image.shape[:2], bool)
    assert metrics.psnr(image, image, mask) is None
    assert metrics.ssim(image, image, mask) is None
    assert metrics.flip(image, image, mask) is None
    assert metrics.rel_mse(image, image, mask) is None
    assert metrics.noise_floor_psnr(image, image, mask) is None


def test_ssim_matches_scikit_image_unmasked(image, rng):
    other = np.clip(image + rng.normal(0, 0.05, image.shape), 0, 1)
    mask = np.ones(image.shape[:2], bool)
    expected = structural_similarity(other, image, data_range=1.0, channel_axis=-1)
    assert metrics.ssim(other, image, mask) == pytest.approx(expected, abs=1e-12)


def test_ssim_stays_in_its_range_when_one_pixel_differs():
    """SSIM is at most 1 (Wang et al. 2004). One changed pixel shifts the rounding of scikit-image's running-sum
    window means along its row, so the windows that hold no changed pixel read a few 1e-16 above 1 there
    (the control below); the value over a mask of identical pixels is exactly 1, never above it."""
    rng = np.random.default_rng(2)
    a = rng.random((40, 40, 3))
    b = a.copy()
    b[20, 3] = 1.0 - np.round(a[20, 3])
    _, raw = structural_similarity(a, b, data_range=1.0, channel_axis=-1, full=True)
    assert raw.max() > 1.0  # the control: the unclipped map leaves SSIM's range
    mask = np.ones((40, 40), bool)
    mask[10:31, :14] = False  # every window holding the changed pixel
    assert metrics.ssim(a, b, mask) == 1.0
    assert metrics.ssim(a, b, np.ones((40, 40), bool)) < 1.0


def test_common_mask_and_erosion():
    a = np.zeros((9, 9), bool)
    a[2:7, 2:7] = True
    b = np.ones((9, 9), bool)
    m = metrics.common_mask(a, b, erode=1)
    expected = np.zeros((9, 9), bool)
    expected[3:6, 3:6] = True
    np.testing.assert_array_equal(m, expected)
    np.testing.assert_array_equal(metrics.common_mask(a, b, erode=0), a)


def test_rel_mse_by_hand():
    ref = np.full((2, 2, 3), 0.5)
    test = ref + 0.1
    mask = np.ones((2, 2), bool)
    assert metrics.rel_mse(test, ref, mask, eps=1e-2) == pytest.approx(0.01 / (0.25 + 0.01))


def test_noise_floor_is_the_psnr_of_one_render_against_the_truth(rng):
    """Statistical check of the +10 log10(2) dB: two noisy copies of a known truth."""
    truth = rng.uniform(0.2, 0.8, size=(200, 200, 3))
    sigma = 0.01
    a = truth + rng.normal(0, sigma, truth.shape)
    b = truth + rng.normal(0, sigma, truth.shape)
    mask = np.ones(truth.shape[:2], bool)
    assert metrics.noise_floor_psnr(a, b, mask) == pytest.approx(metrics.psnr(a, truth, mask), abs=0.05)
    assert metrics.psnr(a, truth, mask) == pytest.approx(-20 * math.log10(sigma), abs=0.05)


def test_compare_json_has_no_infinity(tmp_path):
    """Identical renders: PSNR is the cap, JSON serialisation with allow_nan=False works."""
    import experiments
    import scenes

    scene = scenes.load("builtin:sphere-diffuse")
    rgb = np.full((16, 16, 3), 0.5, np.float32)
    mask = np.zeros((16, 16), bool)
    mask[4:12, 4:12] = True
    r = Render(rgb=rgb, mask=mask, meta={"renderer": "quadrature"})
    out = experiments.compare(r, r, scene)
    assert out["psnr"] == metrics.PSNR_CAP and out["noise_floor_psnr"] == metrics.PSNR_CAP
    json.dumps(out, allow_nan=False)
    empty = Render(rgb=rgb, mask=np.zeros((16, 16), bool), meta={"renderer": "quadrature"})
    out = experiments.compare(empty, r, scene)
    assert out["psnr"] is None and out["pixels"] == 0
    json.dumps(out, allow_nan=False)


@pytest.mark.parametrize(("fraction", "k"), [(0.02, 8), (0.1, 40), (0.5, 200), (0.0125, 5), (0.0101, 5)])
def test_brightest_share_of_a_ramp_by_the_arithmetic_series(fraction, k, rng):
    # pixels 1 .. n in a shuffled order, each channel a different multiple of it (the channel mean is 2 x):
    # the brightest k hold (n + (n - k + 1)) k / 2 of n (n + 1) / 2; k written out by hand, ceil(fraction n)
    # (0.0101 of 400 is 4.04: 5 pixels)
    n = 400
    ramp = rng.permutation(np.arange(1.0, n + 1.0)).reshape(20, 20, 1)
    img = np.concatenate([ramp, 2.0 * ramp, 3.0 * ramp], axis=2)
    expected = (2 * n - k + 1) * k / (n * (n + 1))
    assert metrics.brightest_share(img, np.ones((20, 20), bool), fraction) == pytest.approx(expected, rel=1e-12)


def test_brightest_share_uniform_against_concentrated():
    mask = np.ones((10, 10), bool)
    uniform = np.ones((10, 10, 3))
    assert metrics.brightest_share(uniform, mask, 0.02) == pytest.approx(0.02)
    # 0.07 of 100 pixels is 7 pixels (7 % of the light), where float rounding would ceil to 8
    assert metrics.brightest_share(uniform, mask, 0.07) == pytest.approx(0.07)
    # 0.015 of 100 is 1.5: 2 pixels
    assert metrics.brightest_share(uniform, mask, 0.015) == pytest.approx(0.02)
    # negative control: the same light in one pixel
    one = np.zeros((10, 10, 3))
    one[3, 4] = 100.0
    assert metrics.brightest_share(one, mask, 0.02) == pytest.approx(1.0)


def test_brightest_share_takes_the_channel_mean():
    # red 1 against blue 2: channel means 1/3 and 2/3, so the brighter of the two holds 2/3 (a reading of one
    # channel would rank red first)
    img = np.array([[[1.0, 0.0, 0.0], [0.0, 0.0, 2.0]]])
    assert metrics.brightest_share(img, np.ones((1, 2), bool), 0.5) == pytest.approx(2 / 3)


def test_brightest_share_counts_only_masked_pixels():
    # a bright pixel outside the mask does not count: the masked half is uniform
    img = np.ones((4, 4, 3))
    img[0, 0] = 1000.0
    mask = np.zeros((4, 4), bool)
    mask[2:] = True
    assert metrics.brightest_share(img, mask, 1 / 8) == pytest.approx(1 / 8)


def test_brightest_share_counts_negative_and_non_finite_pixels_as_dark():
    # light 1, 2, 3 beside -5, NaN and Inf: the brightest one of the six holds 3 of 6
    img = np.array([[[-5.0] * 3, [1.0] * 3, [np.nan] * 3, [2.0] * 3, [np.inf] * 3, [3.0] * 3]])
    assert metrics.brightest_share(img, np.ones((1, 6), bool), 1 / 6) == pytest.approx(0.5)


@pytest.mark.parametrize("fraction", [0.0, -0.1, 1.5])
def test_brightest_share_refuses_a_fraction_outside_0_1(fraction):
    with pytest.raises(ValueError, match="fraction"):
        metrics.brightest_share(np.ones((4, 4, 3)), np.ones((4, 4), bool), fraction)


def test_brightest_share_edges():
    img = np.ones((4, 4, 3))
    assert metrics.brightest_share(img, np.zeros((4, 4), bool), 0.1) is None
    assert metrics.brightest_share(np.zeros((4, 4, 3)), np.ones((4, 4), bool), 0.1) is None
    assert metrics.brightest_share(img, np.ones((4, 4), bool), 1.0) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="H, W, C"):
        metrics.brightest_share(np.ones((4, 4)), np.ones((4, 4), bool), 0.1)
