"""Display transform: Reinhard photographic tone mapping, then sRGB encoding (numpy).

Reinhard et al. 2002, "Photographic tone reproduction for digital images", eq. 2 and 4:

    L_m = key / L_avg * 2^exposure * L
    L_d = L_m (1 + L_m / white^2) / (1 + L_m)        (white in key-scaled units)

applied per linear RGB channel (as real-time engines do), clamped to [0, 1] at L_m >= white,
where L_d reaches exactly 1. `L_avg` is the adaptation luminance. It is *not* measured on
each image: iblcheck takes the log-average luminance of the scene's environment
(`adaptation_luminance`), the same for the real-time image and the reference, so metrics
compare like with like (docs/contract.md section 3, step 8).

The GLSL display pass (realtime/shaders/display.frag) implements the same formula and is
tested against this module.
"""

from __future__ import annotations

import numpy as np

from scenes.environment.directions import equirect_solid_angles, luminance

#: Floor added inside the log so black regions do not send the log-average to zero.
LOG_DELTA = 1e-4


def adaptation_luminance(env: np.ndarray, scale: float = 1.0) -> float:
    """Solid-angle-weighted log-average luminance of an equirect environment (Reinhard eq. 1)."""
    env = np.asarray(env, dtype=np.float64)
    w = equirect_solid_angles(env.shape[0], env.shape[1])
    lum = np.maximum(luminance(env) * scale, 0.0)
    return float(np.exp(np.sum(w * np.log(LOG_DELTA + lum)) / np.sum(w)))


def reinhard(rgb: np.ndarray, key: float, white: float, exposure: float, adapt_lum: float) -> np.ndarray:
    """Display-linear values in [0, 1] from linear radiance (any shape), monotone, never NaN.

    Inputs above the white point map to 1 (the formula is evaluated on min(L_m, white), which is
    exact because L_d(white) = 1 and L_d increases monotonically); negative inputs map to 0.
    """
    x = np.asarray(rgb, dtype=np.float64) * (key / max(adapt_lum, 1e-30) * 2.0**exposure)
    x = np.clip(np.nan_to_num(x, nan=0.0, posinf=white, neginf=0.0), 0.0, white)
    return x * (1.0 + x / (white * white)) / (1.0 + x)


def srgb_encode(x: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 sRGB transfer function of display-linear values in [0, 1]."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_decode(v: np.ndarray) -> np.ndarray:
    """Inverse of `srgb_encode` (IEC 61966-2-1): sRGB-encoded values in [0, 1] -> display-linear.

    The break point 0.04045 = 12.92 * 0.0031308 (to the standard's rounding) splits the linear toe
    from the power segment, ((v + 0.055) / 1.055)^2.4 above it.
    """
    v = np.clip(np.asarray(v, dtype=np.float64), 0.0, 1.0)
    return np.where(v <= 0.04045, v / 12.92, np.power((v + 0.055) / 1.055, 2.4))


def tonemap(rgb: np.ndarray, key: float, white: float, exposure: float, adapt_lum: float) -> np.ndarray:
    """Linear radiance -> sRGB-encoded float32 in [0, 1] (Reinhard, then sRGB)."""
    return srgb_encode(reinhard(rgb, key, white, exposure, adapt_lum)).astype(np.float32)


def to_uint8(srgb: np.ndarray) -> np.ndarray:
    """Quantise sRGB values in [0, 1] to 8-bit for PNG output."""
    return np.clip(np.round(np.asarray(srgb) * 255.0), 0, 255).astype(np.uint8)
