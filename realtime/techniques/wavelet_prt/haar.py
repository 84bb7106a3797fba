"""The 2D Haar transform of cube faces and the non-linear selection of lighting coefficients (pure numpy).

Ng, Ramamoorthi & Hanrahan 2003, "All-frequency shadows using non-linear wavelet lighting approximation"
(SIGGRAPH 2003), sections 4-5: lighting and transport are both expanded in an orthonormal 2D Haar basis per
cube face, so that the irradiance E = sum_t L_t T_t over cube texels t equals sum_j (W L)_j (W T)_j (W orthogonal),
and the lighting is approximated non-linearly by its K coefficients of largest area-weighted magnitude.

Transform (the NON-STANDARD 2D decomposition, Stollnitz, DeRose & Salesin, "Wavelets for computer graphics",
1995, section 3.2, as Ng et al. use it): on an s x s face (s a power of two), one step on the n x n top-left
block replaces every row pair (columns 2i, 2i+1) by ((a + b) / sqrt 2, (a - b) / sqrt 2) (sums to the left half,
differences to the right half), then the same on every column pair (sums to the top half), and recurses on
the n/2 x n/2 top-left block until it is 1 x 1. Every step is orthonormal, so the whole transform is: Parseval
holds and the inverse is the transpose. The layout of the s x s coefficients of one face, with h = 1, 2, ...,
s/2 the number of blocks per side of a level:

    [0, 0]                        the scaling coefficient: sum of the face / s (the face's mean times s)
    [r, h + q]  (r, q < h)        "horizontal" detail of block (r, q): (a - b + c - d) s / (4 h)
    [h + r, q]                    "vertical" detail:                   (a + b - c - d) s / (4 h)
    [h + r, h + q]                "diagonal" detail:                   (a - b - c + d) s / (4 h)

where a, b, c, d are the means of the block's four quadrants (top-left, top-right, bottom-left, bottom-right
in (row, column) order), i.e. the four texels of the 2h x 2h level of the face's 2x2 box chain under it. (A
block has side s/h texels; its orthonormal wavelet is +-h/s on each quadrant of (s/2h)^2 texels, so the
coefficient is (h/s)(s/2h)^2 (+-a +-b +-c +-d).) The GPU computes the coefficients from the box chain by this
formula (wavelet_haar.comp); the numpy transform below is the recursive definition.

Area weight (Ng et al. section 5: "weighted by the area of its support"): the fraction of the face a basis
function covers: 1 / h^2 for a detail coefficient of a level with h blocks per side, 1 for the scaling
coefficient (the whole face). Cube parameter area, not solid angle (the selection is what Ng et al. describe;
a global factor does not change it).

Selection key of coefficient j (RGB lighting): area_j x (|c_j,r| + |c_j,g| + |c_j,b|) (equal channel weights).
Rule, ties included: with tau the K-th largest key, every coefficient whose key exceeds tau is kept, and of
those whose key equals tau the ones with the smallest flat index (face, row, column in C order) until K are
kept: exactly K coefficients, deterministic. K >= the number of coefficients keeps all of them.
"""

from __future__ import annotations

import numpy as np

_SQRT_HALF = np.sqrt(0.5)


def _check_size(size: int) -> None:
    if size < 1 or size & (size - 1):
        raise ValueError(f"the Haar transform needs a power-of-two face size, got {size}")


def forward(faces: np.ndarray) -> np.ndarray:
    """Orthonormal non-standard 2D Haar transform of (..., s, s) (per trailing s x s face): same shape, float64."""
    x = np.array(faces, dtype=np.float64)
    size = x.shape[-1]
    if x.ndim < 2 or x.shape[-2] != size:
        raise ValueError(f"the Haar transform needs square faces (..., s, s), got shape {x.shape}")
    _check_size(size)
    n = size
    while n > 1:
        h = n // 2
        block = x[..., :n, :n]
        a, b = block[..., :, 0::2], block[..., :, 1::2]
        rows = np.concatenate([(a + b) * _SQRT_HALF, (a - b) * _SQRT_HALF], axis=-1)
        a, b = rows[..., 0::2, :], rows[..., 1::2, :]
        x[..., :n, :n] = np.concatenate([(a + b) * _SQRT_HALF, (a - b) * _SQRT_HALF], axis=-2)
        n = h
    return x


def inverse(coeffs: np.ndarray) -> np.ndarray:
    """The inverse of `forward` (its transpose): (..., s, s) float64."""
    x = np.array(coeffs, dtype=np.float64)
    size = x.shape[-1]
    _check_size(size)
    n = 2
    while n <= size:
        h = n // 2
        block = x[..., :n, :n]
        lo, hi = block[..., :h, :], block[..., h:, :]
        cols = np.empty_like(block)
        cols[..., 0::2, :] = (lo + hi) * _SQRT_HALF
        cols[..., 1::2, :] = (lo - hi) * _SQRT_HALF
        lo, hi = cols[..., :, :h], cols[..., :, h:]
        out = np.empty_like(block)
        out[..., :, 0::2] = (lo + hi) * _SQRT_HALF
        out[..., :, 1::2] = (lo - hi) * _SQRT_HALF
        x[..., :n, :n] = out
        n *= 2
    return x


def support_areas(size: int) -> np.ndarray:
    """Area weight (s, s) of each coefficient of one face: the fraction of the face its basis function covers."""
    _check_size(size)
    level = np.zeros(size, dtype=np.int64)  # h of the level a row/column index belongs to (0 for index 0)
    for h in (1 << k for k in range(size.bit_length() - 1)):
        level[h:2 * h] = h
    h = np.maximum(level[:, None], level[None, :])  # the coefficient's level: the larger of its row/column h
    area = np.ones((size, size))
    area[h > 0] = 1.0 / h[h > 0].astype(np.float64) ** 2
    return area


def selection_keys(coeffs: np.ndarray) -> np.ndarray:
    """Area-weighted magnitudes (6 s s,) of RGB coefficients (6, s, s, 3), flat in C order (module docstring)."""
    c = np.asarray(coeffs, dtype=np.float64)
    return (support_areas(c.shape[1])[None] * np.abs(c).sum(axis=-1)).reshape(-1)


def select(keys: np.ndarray, k: int) -> np.ndarray:
    """Flat indices (sorted) of the `k` largest keys, ties to the smaller index (module docstring)."""
    keys = np.asarray(keys).reshape(-1)
    if k < 1:
        raise ValueError(f"the selection keeps at least one coefficient, got K = {k}")
    if k >= len(keys):
        return np.arange(len(keys))
    order = np.lexsort((np.arange(len(keys)), -keys))  # by key descending, then index ascending
    return np.sort(order[:k])
