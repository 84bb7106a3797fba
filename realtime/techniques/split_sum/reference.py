"""The exact counterpart of a prefiltered texel: the n = v = r GGX lobe summed over a cube level's texels,

    P(n) = sum_w L(w) D(h(w)) max(n.w, 0) dOmega(w) / sum_w D(h(w)) max(n.w, 0) dOmega(w),
    h(w) = normalize(n + w),

in float64 (the split sum's prefilter, samples.py, estimates it by sampling). A constant map gives the
constant. The weights are shifted by their maximum in log space, so a lobe narrower than a texel gives
finite weights (all on the nearest texels) instead of 0 / 0.
"""

from __future__ import annotations

import numpy as np

from realtime.techniques.split_sum.ggx import alpha_of
from scenes.environment import cubemap


def ggx_texel_weights(size: int, directions: np.ndarray, roughness: float) -> np.ndarray:
    """Normalised weights (k, 6, size, size) of the n = v = r GGX lobe about each direction over the
    texels of a cube level of face `size`."""
    n = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    w = cubemap.texel_directions(size).reshape(-1, 3)
    log_omega = np.tile(np.log(cubemap.texel_solid_angles(size)).reshape(-1), 6)
    alpha = float(alpha_of(roughness))
    a2 = alpha * alpha
    cos_l = n @ w.T  # n.w
    # n.h for h = (n + w) / |n + w|: (1 + n.w) / sqrt(2 (1 + n.w)); cos^2 = (1 + n.w) / 2, sin^2 = (1 - n.w) / 2
    cos2_h = 0.5 * (1.0 + cos_l)
    sin2_h = 0.5 * (1.0 - cos_l)
    f = a2 * cos2_h + sin2_h
    above = cos_l > 0.0
    with np.errstate(divide="ignore"):
        log_w = np.where(above, np.log(a2 / np.pi) - 2.0 * np.log(f) + np.log(np.maximum(cos_l, 1e-300))
                         + log_omega[None, :], -np.inf)
    wts = np.exp(log_w - log_w.max(axis=1, keepdims=True))
    wts /= wts.sum(axis=1, keepdims=True)
    return wts.reshape(-1, 6, size, size)


def ggx_convolve_numpy(faces: np.ndarray, directions: np.ndarray, roughness: float, chunk: int = 64) -> np.ndarray:
    """(k, 3): the lobe-weighted mean of the texels of `faces` (6, s, s, 3) about each of `directions`."""
    faces = np.asarray(faces, dtype=np.float64)
    n = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    L = faces.reshape(-1, 3)
    out = np.empty((len(n), 3))
    for a in range(0, len(n), chunk):
        wts = ggx_texel_weights(faces.shape[1], n[a:a + chunk], roughness)
        out[a:a + chunk] = wts.reshape(len(wts), -1) @ L
    return out
