"""The Haar transform and the lighting selection of wavelet PRT (realtime/techniques/wavelet_prt/haar.py), pure numpy,
against expectations written here: Parseval and an orthogonal basis matrix, the per-block formula of the module
docstring computed from box means, support areas measured on the basis images, and a sort-based selection.
Each property has a deliberately wrong variant (an unnormalised Haar step, magnitudes without area weights)
that the same check rejects."""

from __future__ import annotations

import numpy as np
import pytest

from realtime.techniques.wavelet_prt import haar

SIZES = [1, 2, 4, 8, 16, 32, 64]


def unnormalised_forward(faces: np.ndarray) -> np.ndarray:
    """The non-standard decomposition with averages and half differences (a + b) / 2, (a - b) / 2: the
    common unnormalised Haar, not orthonormal (the negative control)."""
    x = np.array(faces, dtype=np.float64)
    n = x.shape[-1]
    while n > 1:
        block = x[..., :n, :n]
        a, b = block[..., :, 0::2], block[..., :, 1::2]
        rows = np.concatenate([(a + b) / 2, (a - b) / 2], axis=-1)
        a, b = rows[..., 0::2, :], rows[..., 1::2, :]
        x[..., :n, :n] = np.concatenate([(a + b) / 2, (a - b) / 2], axis=-2)
        n //= 2
    return x


@pytest.mark.parametrize("size", SIZES)
def test_round_trip_and_parseval(size):
    x = np.random.default_rng(size).normal(size=(6, size, size))
    c = haar.forward(x)
    np.testing.assert_allclose(haar.inverse(c), x, rtol=0, atol=1e-12)
    assert np.sum(c * c) == pytest.approx(np.sum(x * x), rel=1e-12)
    if size > 1:  # the control: an unnormalised step loses Parseval (the 1 x 1 transform is the identity)
        u = unnormalised_forward(x)
        assert abs(np.sum(u * u) - np.sum(x * x)) > 0.1 * np.sum(x * x)


@pytest.mark.parametrize("size", [*SIZES[:-1], pytest.param(64, marks=pytest.mark.slow)])  # 64: a 4096^2 product
@pytest.mark.parametrize("transform", ["haar", "unnormalised"])
def test_the_matrix_of_basis_images_is_orthogonal(size, transform):
    """Row j of M is the coefficient j of every unit image: M M^T = I exactly when the basis is orthonormal."""
    eye = np.eye(size * size).reshape(-1, size, size)
    fwd = haar.forward if transform == "haar" else unnormalised_forward
    m = fwd(eye).reshape(size * size, size * size).T  # column i = coefficients of unit image i
    orthogonal = np.allclose(m @ m.T, np.eye(size * size), atol=1e-12)
    assert orthogonal == (transform == "haar" or size == 1)


def block_formula(face: np.ndarray) -> np.ndarray:
    """The coefficients by the docstring's per-block formula from the quadrants' means, written apart from
    the recursive transform: s / (4 h) (a -+ b +- c - d) and the scaling coefficient s x mean."""
    s = face.shape[0]
    out = np.zeros((s, s))
    out[0, 0] = s * face.mean()
    h = 1
    while h < s:
        side = s // (2 * h)  # texels per quadrant side
        means = face.reshape(2 * h, side, 2 * h, side).mean(axis=(1, 3))  # the 2h x 2h box level
        a, b, c, d = means[0::2, 0::2], means[0::2, 1::2], means[1::2, 0::2], means[1::2, 1::2]
        k = s / (4 * h)
        out[:h, h:2 * h] = k * (a - b + c - d)
        out[h:2 * h, :h] = k * (a + b - c - d)
        out[h:2 * h, h:2 * h] = k * (a - b - c + d)
        h *= 2
    return out


@pytest.mark.parametrize("size", [2, 4, 16, 64])
def test_layout_is_the_block_formula_of_box_means(size):
    x = np.random.default_rng(7).random((size, size))
    np.testing.assert_allclose(haar.forward(x), block_formula(x), rtol=0, atol=1e-12)
    # control: a transposed face gives other coefficients (the layout is not symmetric in rows and columns)
    assert not np.allclose(haar.forward(x.T), block_formula(x), atol=1e-6)


@pytest.mark.parametrize("size", [1, 2, 8, 32])
def test_support_areas_are_the_supports_of_the_basis_images(size):
    """The fraction of the face where basis image j (the inverse of the unit coefficient j) is non-zero."""
    eye = np.eye(size * size).reshape(-1, size, size)
    images = haar.inverse(eye)
    measured = (np.abs(images) > 1e-12).sum(axis=(1, 2)).reshape(size, size) / size ** 2
    np.testing.assert_allclose(haar.support_areas(size), measured, rtol=0, atol=0)


def sorted_selection(keys: np.ndarray, k: int) -> list[int]:
    """The K kept by Python's sort on (-key, index): the stated rule, written apart."""
    return sorted(sorted(range(len(keys)), key=lambda i: (-keys[i], i))[:k])


@pytest.mark.parametrize("k", [1, 5, 17, 96, 200])
def test_selection_keeps_the_largest_keys_ties_to_the_smaller_index(k):
    rng = np.random.default_rng(k)
    keys = np.round(rng.random(96) * 8) / 8  # many ties
    assert list(haar.select(keys, k)) == sorted_selection(keys, min(k, 96))


def test_selection_keys_weight_by_support_area():
    """One bright texel: the key of each coefficient is |c| x area summed over RGB; the scaling coefficient and
    the three coarsest details tie at 3 L / s (the area weight undoes their smaller magnitude), every finer
    level has a smaller key, so K = 1 keeps the scaling coefficient (the tie goes to index 0). Control: the
    raw magnitudes would keep a finest-level detail instead."""
    s, L = 8, 5.0
    faces = np.zeros((6, s, s, 3))
    faces[2, 5, 3] = L
    coeffs = np.moveaxis(haar.forward(np.moveaxis(faces, -1, 1)), 1, -1)
    keys = haar.selection_keys(coeffs).reshape(6, s, s)
    for r, c in ((0, 0), (0, 1), (1, 0), (1, 1)):  # the scaling coefficient and the h = 1 details
        assert keys[2, r, c] == pytest.approx(3 * L / s)
    assert keys.max() == pytest.approx(3 * L / s)
    assert (keys[2][haar.support_areas(s) < 1] < 3 * L / s - 1e-9).all()
    assert list(haar.select(keys.reshape(-1), 1)) == [2 * s * s]
    raw = np.abs(coeffs).sum(axis=-1).reshape(-1)
    finest = haar.select(raw, 1)[0] - 2 * s * s
    assert finest // s >= s // 2 or finest % s >= s // 2  # a detail of the finest level (h = s / 2)
