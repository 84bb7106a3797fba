"""Image metrics on a common mask (design.md section 7), plain functions with explicit parameters.

Conventions:
- Images are (H, W, 3). `psnr`, `ssim` and `flip` take display values (tone-mapped sRGB in
  [0, 1], `display(scene, rgb)`), `rel_mse` takes linear radiance.
- `mask` (H, W) bool selects the pixels that count; `common_mask` builds it from two coverage
  masks (AND, eroded by 1 pixel so that silhouette pixels, half object half background, are out).
- Defined results at the edges, never NaN or Infinity (JSON has neither):
  identical images give `PSNR_CAP` (100 dB); an empty mask gives None for every metric.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from scenes.tonemap import adaptation_luminance, tonemap

#: PSNR of identical images (an MSE below 1e-10 is reported as 100 dB)
PSNR_CAP = 100.0
#: 10 log10(2): the difference of two independent renders has twice the variance of either
TWO_RENDERS_DB = 10.0 * math.log10(2.0)


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
    from scipy.ndimage import binary_erosion

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


def ssim(test: np.ndarray, reference: np.ndarray, mask: np.ndarray, data_range: float = 1.0) -> float | None:
    """Mean SSIM (scikit-image, 7x7 window, `channel_axis=-1`) over the masked pixels.

    The SSIM map is computed on the whole image and averaged over `mask` minus the 3-pixel border
    scikit-image itself leaves out, so with an all-True mask it equals
    `skimage.metrics.structural_similarity(test, reference, data_range=..., channel_axis=-1)`.
    """
    from skimage.metrics import structural_similarity

    if not mask.any():
        return None
    h, w = mask.shape
    if min(h, w) < 7:
        return None  # the 7x7 window does not fit
    _, smap = structural_similarity(np.asarray(test, np.float64), np.asarray(reference, np.float64),
                                    data_range=data_range, channel_axis=-1, full=True)
    inner = np.zeros_like(mask)
    inner[3:h - 3, 3:w - 3] = True
    sel = mask & inner
    if not sel.any():
        return None
    return float(smap.mean(axis=-1)[sel].mean())


def flip_map(test: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """LDR FLIP error map (H, W) in [0, 1] of display images (flip-evaluator, 67 pixels per degree)."""
    import flip_evaluator

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


def noise_floor_psnr(display_a: np.ndarray, display_b: np.ndarray, mask: np.ndarray) -> float | None:
    """The best PSNR any image can reach against a reference with this much noise.

    Two renders with different seeds differ by noise of twice the variance of either, so
    PSNR(reference, truth) = PSNR(a, b) + 10 log10(2). (design.md section 7 writes "minus 3 dB";
    the sign is corrected here: the noise-free quadrature scores PSNR(a, b) + 2.9 to 3.0 dB
    against a reference, see tests/groundtruth/test_quadrature.py.)
    """
    p = psnr(display_a, display_b, mask)
    return None if p is None else min(PSNR_CAP, p + TWO_RENDERS_DB)
