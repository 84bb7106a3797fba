"""The paper's reflectance in plain numpy (docs/contract.md section 3), for the quadrature and tests.

    f(v, l) cos = (1 - F) kd / pi cos + F ks (N + 1) / (2 pi) max(r . l, 0)^N     for n . l > 0
                  0                                                             below the horizon

with r = reflect(-v, n) the mirror direction and Schlick's F = f0 + (1 - f0) (1 - n.v)^5, n.v
clamped to [0, 1] exactly as the real-time shader does. Where n.v <= 0 (the viewer behind the shading
normal) a one-sided material reflects nothing and a two-sided one uses -n (`face_viewer`).
`diffuse` is the first term alone (F = 0), `phong` the second alone (F = 1), `blend` both. The normalised Phong lobe
(N + 1) / (2 pi) cos^N integrates to 1 over the sphere, so a box-filtered mip texel (an
average) is its real-time stand-in. The Mitsuba plugin (`paper_bsdf.py`) is the same math in drjit.
"""

from __future__ import annotations

import numpy as np

from scenes.model import materials


def schlick(f0: float, n_dot_v: np.ndarray) -> np.ndarray:
    """Schlick's Fresnel (Gu et al. eq. 15) with n.v clamped to [0, 1]: F -> 1 at and beyond grazing."""
    c = np.clip(n_dot_v, 0.0, 1.0)
    return f0 + (1.0 - f0) * (1.0 - c) ** 5


def lobe_weights(material, n_dot_v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(w_diffuse, w_glossy) per shading point: (1, 0) diffuse, (0, 1) phong, (1 - F, F) blend."""
    n_dot_v = np.asarray(n_dot_v, dtype=np.float64)
    fresnel = materials.of(material).fresnel
    if fresnel == "zero":
        return np.ones_like(n_dot_v), np.zeros_like(n_dot_v)
    if fresnel == "one":
        return np.zeros_like(n_dot_v), np.ones_like(n_dot_v)
    f = schlick(material.f0, n_dot_v)
    return 1.0 - f, f


def phong_pow(one_minus_cos: np.ndarray, exponent: float) -> np.ndarray:
    """cos^N computed from 1 - cos (accurate for the narrow lobes of N up to 1e6 and beyond).

    cos^N = exp(N log1p(-(1 - cos))); 0 where cos <= 0; 1 for N = 0 (also at cos = 0, by the
    convention 0^0 = 1 used for a uniform lobe).
    """
    d = np.asarray(one_minus_cos, dtype=np.float64)
    if exponent == 0:
        return np.where(d <= 1.0, 1.0, 0.0)
    with np.errstate(divide="ignore"):
        out = np.exp(exponent * np.log1p(-np.minimum(d, 1.0)))
    return np.where(d < 1.0, out, 0.0)


def phong_lobe(r_dot_l_one_minus: np.ndarray, exponent: float) -> np.ndarray:
    """The normalised lobe (N + 1) / (2 pi) max(r.l, 0)^N, given 1 - r.l."""
    return (exponent + 1.0) / (2.0 * np.pi) * phong_pow(r_dot_l_one_minus, exponent)


def face_viewer(material, normals: np.ndarray, views: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(normals, lit): the back-face rule of scenes/model/materials.py. Where n.v <= 0 a two-sided material's
    normal is flipped towards the viewer; a one-sided material is not lit there (lit False)."""
    behind = np.sum(normals * views, axis=-1) <= 0
    if getattr(material, "two_sided", False):
        return np.where(behind[..., None], -normals, normals), np.ones_like(behind)
    return normals, ~behind


def reflect(v: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Mirror direction of the unit vector towards the viewer `v` about the normal `n`: 2 (n.v) n - v."""
    return 2.0 * np.sum(n * v, axis=-1, keepdims=True) * n - v
