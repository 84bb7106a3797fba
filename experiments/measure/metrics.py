"""Image metrics on a common mask (docs/contract.md section 7), plain functions with explicit parameters.

Conventions:
- Images are (H, W, 3). `psnr`, `ssim` and `flip` take display values (tone-mapped sRGB in
  [0, 1], `display(scene, rgb)`), `rel_mse` takes linear radiance.
- `mask` (H, W) bool selects the pixels that count; `common_mask` builds it from two coverage
  masks (AND, eroded by 1 pixel so that silhouette pixels, half object half background, are out).
- Defined results at the edges, never NaN or Infinity (JSON has neither):
  identical images give `PSNR_CAP` (100 dB); an empty mask gives None for every metric.
- `no_signal(reference, mask)`: why a comparison would measure nothing (too few pixels, a black
  reference, a reference clipped white); experiments/measure/pair.py then reports every metric as None.
  `white_share` says how much of a comparison the tone mapping has clipped.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from scipy.ndimage import binary_erosion
from skimage.metrics import structural_similarity

from scenes.model.tonemap import adaptation_luminance, tonemap

#: PSNR of identical images (an MSE below 1e-10 is reported as 100 dB)
PSNR_CAP = 100.0
#: 10 log10(2): the difference of two independent renders has twice the variance of either
TWO_RENDERS_DB = 10.0 * math.log10(2.0)
#: the side of scikit-image's SSIM window (its default, `win_size=7`)
SSIM_WINDOW = 7
#: a comparison of fewer covered pixels than this carries no signal (`no_signal`): a 2 x 2 patch is the
#: least that still shows a gradient; fewer pixels are a silhouette's edge, not an image
MIN_PIXELS = 4
#: a reference pixel is lit when one channel of its display value reaches half an 8-bit step: below
#: it, the pixel is black in every 8-bit picture of the reference
LIT = 0.5 / 255
#: a reference pixel is white when every channel of its display value is within half an 8-bit step of 1:
#: the tone mapping has clipped it at its white point, so a test pixel as bright or brighter displays the same
WHITE = 1.0 - 0.5 / 255


def no_signal(reference: np.ndarray, mask: np.ndarray, min_pixels: int = MIN_PIXELS) -> str | None:
    """Why comparing against `reference` (display values) over `mask` would measure nothing, or None.

    A comparison carries no signal when it counts fewer than `min_pixels` pixels, when no counted
    pixel of the reference is lit (`LIT`): a black reference matches a black test image with PSNR 100
    and SSIM 1, which says nothing about the technique (the camera inside a one-sided sphere, a light
    behind the object); or, the same at the other end, when every counted pixel of the reference is
    white (`WHITE`): the tone mapping has clipped the whole object (a bright probe whose log-average,
    and so the exposure, is set by its dark parts), and any test image as bright scores PSNR 100. Such a
    comparison's metrics are None (experiments/measure/pair.py).
    """
    n = int(mask.sum())
    if n == 0:
        return "no pixel is covered in both images (is the object outside the view?)"
    if n < min_pixels:
        return f"{n} covered pixel{'s' * (n != 1)}, fewer than the {min_pixels} a comparison needs"
    if not (np.asarray(reference)[mask] >= LIT).any():
        return f"no lit pixel in the reference (all {n} covered pixels display as black)"
    if not (np.asarray(reference)[mask] < WHITE).any():
        return (f"no pixel of the reference below white (all {n} covered pixels display as white: the tone mapping "
                f"clips them; a lower tonemap.exposure shows them)")
    return None


def white_share(reference: np.ndarray, mask: np.ndarray) -> float | None:
    """The share of the counted pixels whose reference displays as white (every channel at least `WHITE`):
    where the tone mapping has clipped the reference, a test image too bright by any amount shows no error.
    None for an empty mask."""
    if not mask.any():
        return None
    return float(np.all(np.asarray(reference)[mask] >= WHITE, axis=-1).mean())


def display(scene, rgb: np.ndarray) -> np.ndarray:
    """The scene's tone mapping (Reinhard with the environment's log-average luminance, then sRGB).

    The same parameters for every image of a scene (never an image-adaptive key per image).
    """
    tm = scene.tonemap
    return tonemap(rgb, tm.key, tm.white, tm.exposure, _adaptation(scene.environment))


@lru_cache(maxsize=32)
def _adaptation(environment) -> float:
    """The environment's log-average luminance, once per (frozen, hashable) environment setting."""
    return adaptation_luminance(environment.radiance())


def common_mask(mask_a: np.ndarray, mask_b: np.ndarray, erode: int = 1) -> np.ndarray:
    """mask_a AND mask_b, eroded by `erode` pixels (a 3x3 cross per step)."""
    m = np.asarray(mask_a, bool) & np.asarray(mask_b, bool)
    return binary_erosion(m, iterations=erode, border_value=0) if erode > 0 and m.any() else m


def psnr(test: np.ndarray, reference: np.ndarray, mask: np.ndarray, data_range: float = 1.0) -> float | None:
    """10 log10(data_range^2 / MSE) over the masked pixels and all channels; PSNR_CAP when equal."""
    if not mask.any():
        return None
    mse = float(np.mean((np.asarray(test, np.float64)[mask] - np.asarray(reference, np.float64)[mask]) ** 2))
    if mse <= data_range**2 * 10 ** (-PSNR_CAP / 10):
        return PSNR_CAP
    return 10.0 * math.log10(data_range**2 / mse)


class SSIMResult(NamedTuple):
    """Result of `ssim(..., full=True)`: the mean, the map it averages and the pixels it averages over."""

    value: float | None
    map: np.ndarray | None
    selection: np.ndarray | None


def ssim_selection(mask: np.ndarray, win_size: int = SSIM_WINDOW) -> np.ndarray:
    """`mask` without the border of (win_size - 1) / 2 pixels that scikit-image leaves out of its mean."""
    h, w = mask.shape
    pad = (win_size - 1) // 2
    inner = np.zeros_like(mask, dtype=bool)
    inner[pad:h - pad, pad:w - pad] = True
    return np.asarray(mask, bool) & inner


def ssim(test: np.ndarray, reference: np.ndarray, mask: np.ndarray, data_range: float = 1.0,
         *, full: bool = False) -> float | None | SSIMResult:
    """Mean SSIM (scikit-image, 7x7 window, `channel_axis=-1`) over the masked pixels.

    Parameters
    ----------
    test, reference : ndarray, shape (H, W, 3)
        Display values (`display(scene, rgb)`), compared as float64.
    mask : ndarray of bool, shape (H, W)
        Pixels that count.
    data_range : float, optional
        The data range of the images (1 for display values).
    full : bool, optional
        Also return the SSIM map and the pixels averaged (as `skimage.metrics.structural_similarity`'s
        `full=True` does).

    Returns
    -------
    float or None
        The mean of the channel-mean SSIM map over `mask` minus the 3-pixel border scikit-image itself
        leaves out (`ssim_selection`), so that with an all-True mask it equals
        `skimage.metrics.structural_similarity(test, reference, data_range=..., channel_axis=-1)` up to
        rounding: the map is clipped to [-1, 1], SSIM's range, which rounding can leave by ~1e-15.
        None when the mask is empty, the 7x7 window does not fit, or no masked pixel is inside the border.
    SSIMResult
        With `full`: ``(value, map, selection)``, where ``map`` is the (H, W) channel-mean SSIM map of the
        whole image (None when the mask is empty or the window does not fit) and ``selection`` the pixels
        ``value`` averages (``value == map[selection].mean()``).
    """
    none = SSIMResult(None, None, None) if full else None
    if not mask.any():
        return none
    h, w = mask.shape
    if min(h, w) < SSIM_WINDOW:
        return none  # the 7x7 window does not fit
    _, smap = structural_similarity(np.asarray(test, np.float64), np.asarray(reference, np.float64),
                                    data_range=data_range, channel_axis=-1, full=True)
    # SSIM lies in [-1, 1] (Wang et al. 2004, eq. 13 and its Cauchy-Schwarz bound), but scikit-image's local
    # means are running sums (scipy's uniform_filter): one pixel that differs changes their rounding along its
    # whole row, so windows identical in both images read 1 + a few 1e-16 and their mean can exceed 1
    channel_mean = np.clip(smap, -1.0, 1.0).mean(axis=-1)
    sel = ssim_selection(mask)
    value = float(channel_mean[sel].mean()) if sel.any() else None
    return SSIMResult(value, channel_mean, sel) if full else value


def flip_map(test: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """LDR FLIP error map (H, W) in [0, 1] of display images (flip-evaluator, 67 pixels per degree)."""
    import flip_evaluator  # deferred: a compiled extension, loaded only when FLIP is computed

    ref = np.ascontiguousarray(np.clip(reference, 0, 1), dtype=np.float32)
    tst = np.ascontiguousarray(np.clip(test, 0, 1), dtype=np.float32)
    err, _, _ = flip_evaluator.evaluate(ref, tst, "LDR", applyMagma=False, computeMeanError=False)
    err = np.asarray(err, dtype=np.float64)
    return err[..., 0] if err.ndim == 3 else err


def flip(test: np.ndarray, reference: np.ndarray, mask: np.ndarray) -> float | None:
    """Mean LDR FLIP over the masked pixels (0 = identical)."""
    if not mask.any():
        return None
    return float(flip_map(test, reference)[mask].mean())


def rel_mse(test: np.ndarray, reference: np.ndarray, mask: np.ndarray, eps: float = 1e-2) -> float | None:
    """Relative MSE of linear radiance, mean of (test - ref)^2 / (ref^2 + eps) (Rousselle et al. 2011)."""
    if not mask.any():
        return None
    t = np.asarray(test, np.float64)[mask]
    r = np.asarray(reference, np.float64)[mask]
    return float(np.mean((t - r) ** 2 / (r * r + eps)))


def brightest_share(image: np.ndarray, mask: np.ndarray, fraction: float) -> float | None:
    """The share of a linear image's light that its brightest `fraction` of the masked pixels hold.

    `image` is (H, W, C) and `mask` (H, W). A pixel's light is its channel mean; negative values (the noise
    of a difference of two renders of a non-negative quantity) and non-finite ones count as 0. The brightest
    k = ceil(fraction n) of the n masked pixels are taken (fraction n rounded to 9 decimals first, so that
    0.07 of 100 pixels is 7, not the 8 that float rounding gives): a uniform image gives k / n, an image
    whose light is all in k pixels or fewer 1. None where the mask is empty or holds no light. A mean ratio
    of two images can agree while their light sits in very different pixels: this says how concentrated
    each one's is."""
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"fraction must be in (0, 1], got {fraction}")
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[:2] != mask.shape:
        raise ValueError(f"image must be (H, W, C) over a (H, W) mask, got {image.shape} and {mask.shape}")
    if not mask.any():
        return None
    v = np.asarray(image, np.float64)[mask].mean(axis=-1)
    v = np.where(np.isfinite(v), np.maximum(v, 0.0), 0.0)
    total = float(v.sum())
    if total <= 0.0:
        return None
    k = math.ceil(round(fraction * v.size, 9))
    return float(np.sort(v)[-k:].sum() / total)


def noise_floor_psnr(display_a: np.ndarray, display_b: np.ndarray, mask: np.ndarray) -> float | None:
    """The best PSNR any image can reach against a reference with this much noise.

    Two renders with different seeds differ by noise of twice the variance of either, so
    PSNR(reference, truth) = PSNR(a, b) + 10 log10(2). (docs/contract.md section 7 writes "minus 3 dB";
    the sign is corrected here: the noise-free quadrature scores PSNR(a, b) + 2.9 to 3.0 dB
    against a reference, see tests/groundtruth/test_quadrature.py.)
    """
    p = psnr(display_a, display_b, mask)
    return None if p is None else min(PSNR_CAP, p + TWO_RENDERS_DB)


#: `psnr_unbiased`'s default floor: an excess error is resolved when it is this many standard errors above zero
UNBIASED_FLOOR_SE = 2.0


class UnbiasedPSNR(NamedTuple):
    """Result of `psnr_unbiased`: unpacks as `value, clamped = psnr_unbiased(...)` (JSON: a 2-list)."""

    value: float | None
    clamped: bool


def psnr_unbiased(test: np.ndarray, reference: np.ndarray, reference2: np.ndarray, mask: np.ndarray,
                  data_range: float = 1.0, floor_se: float = UNBIASED_FLOOR_SE) -> UnbiasedPSNR:
    """PSNR of `test` against the noise-free truth, estimated from two noisy references.

    A Monte Carlo reference is the truth plus zero-mean noise, so the plain MSE against it is the
    test's own error plus the reference's noise variance, and `psnr` is biased low. This removes
    the reference's variance, estimated from a second, independent render.

    Parameters
    ----------
    test : ndarray, shape (H, W, 3)
        The image under test, display values (`display(scene, rgb)`).
    reference : ndarray, shape (H, W, 3)
        The reference render, display values with the same tone mapping.
    reference2 : ndarray, shape (H, W, 3)
        A render of the same reference with another seed (independent noise), display values.
    mask : ndarray of bool, shape (H, W)
        Pixels that count; pass the common mask of all three images.
    data_range : float, optional
        The data range of the images (1 for display values).
    floor_se : float, optional
        The floor, in standard errors of the estimate (see Notes). Default `UNBIASED_FLOOR_SE` = 2.

    Returns
    -------
    UnbiasedPSNR
        ``value``: ``10 log10(data_range**2 / max(MSE_u, floor))``, at most `PSNR_CAP`; None for an
        empty mask. ``clamped``: True when ``MSE_u <= floor``, i.e. the test image is as close to the
        truth as this reference can tell, and ``value`` is that resolution limit, not a measurement.

    Notes
    -----
    Over the N masked pixels (all channels), with the test image t and the references r, r2::

        MSE   = mean((t - r)^2)                    E[MSE] = MSE(t, truth) + var
        var   = mean((r - r2)^2) / 2               E[var] = var (r, r2 independent, same variance)
        MSE_u = MSE - var = mean(d),  d_p = mean over channels of (t - r)^2 - (r - r2)^2 / 2

    so ``MSE_u`` is an unbiased estimate of ``MSE(t, truth)``. It is itself noisy: its standard error
    is ``se = std(d_p) / sqrt(N)`` over the pixels (the pixel is the sampling unit: the channels of
    one pixel share paths and are correlated, different pixels are independent with the box
    reconstruction filter of the references). An ``MSE_u`` within ``floor_se`` standard errors of zero
    cannot be told from zero (at ``floor_se = 2``, one-sided 97.7 %), so the floor is
    ``floor = max(floor_se * se, data_range**2 * 10**(-PSNR_CAP / 10))``. The floor is the noise-limited
    resolution of this reference and pixel count; for Gaussian noise of variance s^2 and a test
    equal to the truth, ``se = s^2 sqrt(2 / (3 N))``. The result is continuous in ``MSE_u``: the
    value never exceeds the floor's PSNR. With a noise-free reference (r2 == r) ``var = 0`` and the
    result is `psnr` up to that floor.

    The estimate of the log of a ratio is slightly biased (Jensen); for a resolved error (``MSE_u``
    well above ``se``) that bias is ``~ -(10 / ln 10) (se / MSE_u)^2 / 2`` dB, negligible.

    References
    ----------
    .. [1] For independent X, Y of equal variance, E[(X - Y)^2] / 2 = Var X. In rendering: Rousselle,
       Knaus and Zwicker, "Adaptive rendering with non-local means filtering", ACM TOG 31(6), 2012
       (SIGGRAPH Asia), section 4: the variance of a render from two half-buffers of independent samples.
    .. [2] Efron and Tibshirani, "An Introduction to the Bootstrap", 1993, ch. 2 (standard error
       of a mean).
    """
    if not mask.any():
        return UnbiasedPSNR(None, False)
    t, r, r2 = (np.asarray(x, np.float64)[mask] for x in (test, reference, reference2))
    d = ((t - r) ** 2 - 0.5 * (r - r2) ** 2).reshape(t.shape[0], -1).mean(axis=1)
    est = float(d.mean())
    se = float(d.std(ddof=1) / math.sqrt(d.size)) if d.size > 1 else 0.0
    floor = max(floor_se * se, data_range**2 * 10 ** (-PSNR_CAP / 10))
    value = min(PSNR_CAP, 10.0 * math.log10(data_range**2 / max(est, floor)))
    return UnbiasedPSNR(value, bool(est <= floor))
