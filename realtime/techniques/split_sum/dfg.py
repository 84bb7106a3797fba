"""The split sum's second table, the DFG pair (A, B), in numpy: the mirror of dfg_lut.comp.

The directional albedo of the GGX lobe with Schlick's Fresnel F = F0 + (1 - F0) Fc, Fc = (1 - v.h)^5,
splits into two integrals that do not depend on F0 (Karis 2013):

    E(v) = int F D V (n.l) dl = F0 A + B,   A = int (1 - Fc) D V (n.l) dl,   B = int Fc D V (n.l) dl,

so A + B = E of F0 = 1, the lobe's single-scattering albedo (<= 1, -> 1 as roughness -> 0). Every engine
tabulates them the same way (Khronos' glTF-IBL-Sampler LUT(), Filament's CubemapIBL DFV, three.js'
generateDFGLUT.js): half vectors h importance-sampled with density D(h) n.h (the Hammersley set,
ggx.importance_half_vectors), l = reflect(-v, h), pdf(l) = D n.h / (4 v.h), so each sample adds
V (v.h) (n.l) / (n.h) times 4 / N:

    A = 4 / N sum (1 - Fc) V (v.h) (n.l) / (n.h),   B = 4 / N sum Fc V (v.h) (n.l) / (n.h)   over n.l > 0,

with v = (sqrt(1 - (n.v)^2), 0, n.v) in the frame z = n. The table is indexed by (n.v, roughness) at texel
centres: texel (i, j) of a size^2 table holds n.v = (i + 0.5) / size, roughness = (j + 0.5) / size
(Khronos' LUT pass reads its fragment's texCoord, three.js' generator (x + 0.5) / size), read with
bilinear filtering and clamping at the edges. Rows are roughness, columns n.v. alpha is the material's,
roughness^2 clamped at PBR_MIN_ALPHA (the engines clamp the roughness before the lookup instead).

Precision, as the engines ship the table: "f32"; "f16" (Filament's RGB16F dfg.inc, three.js' RG16F
DFGLUTData, Khronos' HALF_FLOAT render target); "u8" (8-bit unorm, a PNG's: Khronos' old lut_ggx.png,
Babylon's 8-bit BRDF texture).
"""

from __future__ import annotations

import numpy as np

from realtime.techniques.split_sum.ggx import alpha_of, importance_half_vectors, visibility

PRECISIONS = ("f32", "f16", "u8")


def dfg_pair(n_dot_v, roughness: float, samples: int, kind: str = "height_correlated") -> tuple[np.ndarray, np.ndarray]:
    """(A, B) at each n.v of the array `n_dot_v` for one roughness (the sum in the module docstring)."""
    nv = np.asarray(n_dot_v, dtype=np.float64).reshape(-1)
    alpha = float(alpha_of(roughness))
    h, _ = importance_half_vectors(alpha, samples)  # (n, 3)
    v = np.stack([np.sqrt(np.maximum(1.0 - nv * nv, 0.0)), np.zeros_like(nv), nv], axis=-1)  # (k, 3)
    vh = np.clip(v @ h.T, 0.0, 1.0)  # (k, n)
    nh = np.clip(h[:, 2], 0.0, 1.0)[None, :]
    nl = 2.0 * vh * nh - nv[:, None]  # l.z of l = 2 (v.h) h - v
    valid = nl > 0.0
    nl_safe = np.where(valid, nl, 1.0)
    w = np.where(valid, visibility(nl_safe, nv[:, None], alpha, kind) * vh * nl_safe / nh, 0.0)
    fc = (1.0 - vh) ** 5
    scale = 4.0 / samples
    return scale * np.sum((1.0 - fc) * w, axis=1), scale * np.sum(fc * w, axis=1)


def dfg_table(size: int, samples: int, kind: str = "height_correlated") -> np.ndarray:
    """(size, size, 2) float64: [j, i] = (A, B) at n.v = (i + 0.5) / size, roughness = (j + 0.5) / size."""
    centres = (np.arange(size) + 0.5) / size
    out = np.empty((size, size, 2))
    for j, r in enumerate(centres):
        a, b = dfg_pair(centres, r, samples, kind)
        out[j, :, 0], out[j, :, 1] = a, b
    return out


def quantise(table: np.ndarray, precision: str) -> np.ndarray:
    """The values a texture of `precision` stores (round to nearest): float32, float16, or unorm8
    (clamped to [0, 1], round(255 x) / 255)."""
    t = np.asarray(table, dtype=np.float64)
    if precision == "f32":
        return t.astype(np.float32).astype(np.float64)
    if precision == "f16":
        return t.astype(np.float16).astype(np.float64)
    if precision == "u8":
        return np.round(np.clip(t, 0.0, 1.0) * 255.0) / 255.0
    raise ValueError(f"precision must be one of {', '.join(PRECISIONS)}, got {precision!r}")


def lookup(table: np.ndarray, n_dot_v, roughness) -> np.ndarray:
    """Bilinear read of a (size, size, C) table at (n.v, roughness) with texel centres at (i + 0.5) /
    size and clamping at the edges, as a GL_LINEAR, CLAMP_TO_EDGE sampler reads it. Returns (..., C)."""
    t = np.asarray(table, dtype=np.float64)
    size_r, size_v = t.shape[:2]
    x = np.clip(np.asarray(n_dot_v, dtype=np.float64), 0.0, 1.0) * size_v - 0.5
    y = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0) * size_r - 0.5
    x0 = np.floor(x)
    y0 = np.floor(y)
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]
    i0 = np.clip(x0.astype(int), 0, size_v - 1)
    i1 = np.clip(x0.astype(int) + 1, 0, size_v - 1)
    j0 = np.clip(y0.astype(int), 0, size_r - 1)
    j1 = np.clip(y0.astype(int) + 1, 0, size_r - 1)
    top = t[j0, i0] * (1.0 - fx) + t[j0, i1] * fx
    bottom = t[j1, i0] * (1.0 - fx) + t[j1, i1] * fx
    return top * (1.0 - fy) + bottom * fy
