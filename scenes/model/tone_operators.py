"""The tone-mapping operators real-time engines apply before writing an 8-bit image (pure numpy).

An engine that writes a tone-mapped sRGB image (a PNG from three.js, Babylon.js, a game engine) has put
its linear radiance through one of these curves and then the sRGB encoding. To score such an image,
iblcheck puts the reference through the same named curve and exposure (`apply`), then `srgb_encode`
(scenes/model/tonemap.py), and compares in display space (docs/contract.md, the display-space rule).

Every operator takes linear Rec.709 RGB radiance of shape (..., 3) and returns display-linear values
in [0, 1], before the sRGB transfer function. Each formula is transcribed from three.js, file
src/renderers/shaders/ShaderChunk/tonemapping_pars_fragment.glsl.js (r16x), except `aces-narkowicz`,
from Narkowicz 2015 (below). GLSL's `mat3(c0, c1, c2)` takes *columns*: the matrices below are written
exactly as the GLSL lists its vectors (one column per row of the numpy literal), and applied to row
vectors as `rgb @ M`, which is `M_glsl * rgb` for each pixel.

NaN input is refused (a ValueError naming where): a NaN pixel is a broken image, not a colour. Inf
and very large values are finite after each curve (each saturates).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: The operators, in the order the CLI lists them.
NAMES = ("none", "reinhard", "aces-hill", "aces-narkowicz", "khronos-pbr-neutral", "agx")

#: Largest radiance fed to a curve: every curve has saturated long before, and the rational and
#: log2 forms stay finite (x^2 < 1e308) for anything clipped to it. Applied to +Inf as well.
_CLIP = 1e30


# --------------------------------------------------------------------------- none
def _none(x: np.ndarray) -> np.ndarray:
    # three.js LinearToneMapping: saturate( toneMappingExposure * color ).
    return np.clip(x, 0.0, 1.0)


# --------------------------------------------------------------------------- reinhard
def _reinhard(x: np.ndarray) -> np.ndarray:
    # three.js ReinhardToneMapping: saturate( color / ( 1 + color ) ), per channel (Reinhard 2002,
    # eq. 3, without the key scaling and white point of iblcheck's own display transform).
    x = np.maximum(x, 0.0)
    return np.clip(x / (1.0 + x), 0.0, 1.0)


# --------------------------------------------------------------------------- aces-hill
# three.js ACESFilmicToneMapping: Stephen Hill's fit of the ACES RRT + ODT (sRGB, D65) with its
# input and output matrices, after three's brighter-viewing prescale `color *= exposure / 0.6`.
#   ACESInputMat  (sRGB => XYZ => D65_2_D60 => AP1 => RRT_SAT), GLSL columns:
_ACES_IN = np.array([[0.59719, 0.07600, 0.02840],
                     [0.35458, 0.90834, 0.13383],
                     [0.04823, 0.01566, 0.83777]])
#   ACESOutputMat (ODT_SAT => XYZ => D60_2_D65 => sRGB), GLSL columns:
_ACES_OUT = np.array([[1.60475, -0.10208, -0.00327],
                      [-0.53108, 1.10813, -0.07276],
                      [-0.07367, -0.00605, 1.07602]])
#: three.js's prescale (a subjective 1/0.6 to suit a brighter viewing environment)
ACES_HILL_PRESCALE = 1.0 / 0.6


def rrt_and_odt_fit(v: np.ndarray) -> np.ndarray:
    """Hill's rational fit: (v (v + 0.0245786) - 0.000090537) / (v (0.983729 v + 0.4329510) + 0.238081)."""
    a = v * (v + 0.0245786) - 0.000090537
    b = v * (0.983729 * v + 0.4329510) + 0.238081
    return a / b


def _aces_hill(x: np.ndarray) -> np.ndarray:
    c = (x * ACES_HILL_PRESCALE) @ _ACES_IN
    c = rrt_and_odt_fit(c)
    return np.clip(c @ _ACES_OUT, 0.0, 1.0)


# --------------------------------------------------------------------------- aces-narkowicz
# Krzysztof Narkowicz, "ACES Filmic Tone Mapping Curve" (blog, 2016-01-06, knarkowicz.wordpress.com):
# a luminance-only fit of ODT(RRT(x)) applied per channel, data pre-exposed so that 1 maps to ~0.8
# (no 0.6 prescale: "for the original ACES curve just multiply input by 0.6"). This is the curve
# Unreal Engine 4 style engines and Babylon.js-era shaders copied:
#   saturate( x (a x + b) / (x (c x + d) + e) ),  a = 2.51, b = 0.03, c = 2.43, d = 0.59, e = 0.14
_NARKOWICZ = (2.51, 0.03, 2.43, 0.59, 0.14)


def _aces_narkowicz(x: np.ndarray) -> np.ndarray:
    a, b, c, d, e = _NARKOWICZ
    x = np.maximum(x, 0.0)
    return np.clip(x * (a * x + b) / (x * (c * x + d) + e), 0.0, 1.0)


# --------------------------------------------------------------------------- khronos-pbr-neutral
# three.js NeutralToneMapping: the Khronos PBR Neutral tone mapper (Khronos 3D Commerce, 2024):
#   x = min(r, g, b); offset = x < 0.08 ? x - 6.25 x^2 : 0.04; color -= offset
#   peak = max(r, g, b); identity while peak < StartCompression = 0.8 - 0.04
#   d = 1 - StartCompression; newPeak = 1 - d^2 / (peak + d - StartCompression); color *= newPeak / peak
#   g = 1 - 1 / (Desaturation (peak - newPeak) + 1), Desaturation = 0.15; mix(color, newPeak, g)
PBR_NEUTRAL_START = 0.8 - 0.04
PBR_NEUTRAL_DESATURATION = 0.15


def _khronos_pbr_neutral(x: np.ndarray) -> np.ndarray:
    x = np.maximum(x, 0.0)  # the GLSL has no clamp; a display value below 0 is clipped at the end
    low = np.min(x, axis=-1, keepdims=True)
    offset = np.where(low < 0.08, low - 6.25 * low * low, 0.04)
    c = x - offset
    peak = np.max(c, axis=-1, keepdims=True)
    d = 1.0 - PBR_NEUTRAL_START
    # the denominator is >= d wherever the compressed branch is taken; the floor only keeps the
    # discarded branch (peak < StartCompression) free of divisions by zero
    new_peak = 1.0 - d * d / np.maximum(peak + d - PBR_NEUTRAL_START, d)
    safe_peak = np.where(peak > 0.0, peak, 1.0)
    scaled = c * (new_peak / safe_peak)
    g = 1.0 - 1.0 / (PBR_NEUTRAL_DESATURATION * (peak - new_peak) + 1.0)
    compressed = scaled * (1.0 - g) + new_peak * g
    return np.clip(np.where(peak < PBR_NEUTRAL_START, c, compressed), 0.0, 1.0)


# --------------------------------------------------------------------------- agx
# three.js AgXToneMapping (after Troy Sobotka's AgX via Filament and iolite's minimal implementation):
# to linear Rec.2020, AgX inset matrix, log2 encoding between AgxMinEv and AgxMaxEv, the sixth-order
# polynomial approximation of the default contrast sigmoid, the outset matrix, the 2.2 power back to
# linear, back to linear sRGB, clamp. Matrices as the GLSL lists them (columns).
_SRGB_TO_REC2020 = np.array([[0.6274, 0.0691, 0.0164],
                             [0.3293, 0.9195, 0.0880],
                             [0.0433, 0.0113, 0.8956]])
_REC2020_TO_SRGB = np.array([[1.6605, -0.1246, -0.0182],
                             [-0.5876, 1.1329, -0.1006],
                             [-0.0728, -0.0083, 1.1187]])
_AGX_INSET = np.array([[0.856627153315983, 0.137318972929847, 0.11189821299995],
                       [0.0951212405381588, 0.761241990602591, 0.0767994186031903],
                       [0.0482516061458583, 0.101439036467562, 0.811302368396859]])
_AGX_OUTSET = np.array([[1.1271005818144368, -0.1413297634984383, -0.14132976349843826],
                        [-0.11060664309660323, 1.157823702216272, -0.11060664309660294],
                        [-0.016493938717834573, -0.016493938717834257, 1.2519364065950405]])
AGX_MIN_EV = -12.47393  # log2(2^-10 * 0.18), the log encoding's black
AGX_MAX_EV = 4.026069  # log2(2^6.5 * 0.18), its white


def agx_default_contrast_approx(x: np.ndarray) -> np.ndarray:
    """15.5 x^6 - 40.14 x^5 + 31.96 x^4 - 6.868 x^3 + 0.4298 x^2 + 0.1191 x - 0.00232."""
    x2 = x * x
    x4 = x2 * x2
    return 15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x - 0.00232


def _agx(x: np.ndarray) -> np.ndarray:
    c = x @ _SRGB_TO_REC2020
    c = c @ _AGX_INSET
    c = np.log2(np.maximum(c, 1e-10))
    c = np.clip((c - AGX_MIN_EV) / (AGX_MAX_EV - AGX_MIN_EV), 0.0, 1.0)
    c = agx_default_contrast_approx(c)
    c = c @ _AGX_OUTSET
    c = np.power(np.maximum(c, 0.0), 2.2)
    c = c @ _REC2020_TO_SRGB
    return np.clip(c, 0.0, 1.0)


_OPERATORS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "none": _none, "reinhard": _reinhard, "aces-hill": _aces_hill, "aces-narkowicz": _aces_narkowicz,
    "khronos-pbr-neutral": _khronos_pbr_neutral, "agx": _agx,
}


def apply(name: str, linear_rgb: np.ndarray, exposure: float = 1.0) -> np.ndarray:
    """Display-linear float64 values in [0, 1] of linear RGB radiance (..., 3) under operator `name`.

    `exposure` multiplies the radiance first, as three.js's `toneMappingExposure` (aces-hill adds its
    own 1/0.6 on top). ValueError for an unknown name, a bad exposure, a non-RGB shape or NaN input.
    """
    if name not in _OPERATORS:
        raise ValueError(f"tone mapping {name!r} is unknown; choose one of {', '.join(NAMES)}")
    if not (np.isfinite(exposure) and exposure > 0.0):
        raise ValueError(f"exposure {exposure!r} must be a finite number > 0")
    x = np.asarray(linear_rgb, dtype=np.float64)
    if x.ndim < 1 or x.shape[-1] != 3:
        raise ValueError(f"tone mapping expects linear RGB of shape (..., 3), got {x.shape}")
    if np.isnan(x).any():
        raise ValueError(f"tone mapping {name!r}: the input holds {int(np.isnan(x).sum())} NaN value(s)")
    x = np.clip(x * float(exposure), -_CLIP, _CLIP)
    return _OPERATORS[name](x)
