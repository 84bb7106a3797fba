"""The GGX microfacet lobe of glTF's metallic-roughness material (docs/contract.md section 3b), in numpy
float64: its alpha, distribution, visibility terms and the two ways engines warp a Hammersley point into a
half vector. The split sum's sample sets (samples.py), its DFG table's mirror (dfg.py) and the exact
references of the tests are built from these.

    alpha = max(roughness^2, PBR_MIN_ALPHA)
    D(h)  = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)

Visibility V = G2 / (4 n.l n.v), two forms of Smith's masking-shadowing (Heitz 2014, "Understanding the
Masking-Shadowing Function in Microfacet-Based BRDFs", eqs. 98-99), with Lambda-term
a(x) = sqrt(alpha^2 + (1 - alpha^2) x^2):

    height-correlated   V = 0.5 / (n.v a(n.l) + n.l a(n.v))          (what every engine's DFG table uses)
    separable           V = 1 / ((n.l + a(n.l)) (n.v + a(n.v)))        (glTF 2.0 Appendix B as written)

Both equal 1 / 4 at n.l = n.v = 1 and differ by a few % at grazing angles and high roughness.
"""

from __future__ import annotations

import numpy as np

from realtime.engine.low_discrepancy import hammersley
from scenes.model.materials import PBR_MIN_ALPHA

VISIBILITIES = ("height_correlated", "separable")


def alpha_of(roughness) -> np.ndarray:
    """GGX alpha of glTF's perceptual roughness: roughness^2, never below PBR_MIN_ALPHA."""
    return np.maximum(np.asarray(roughness, dtype=np.float64) ** 2, PBR_MIN_ALPHA)


def ndf(cos_h, alpha) -> np.ndarray:
    """GGX D(h) of cos_h = n.h (0 where n.h <= 0). The denominator is written as
    alpha^2 cos^2 + sin^2 so that it keeps its precision for a lobe of alpha ~ 1e-3 near n.h = 1."""
    c = np.asarray(cos_h, dtype=np.float64)
    a2 = np.asarray(alpha, dtype=np.float64) ** 2
    c2 = np.minimum(c * c, 1.0)
    f = a2 * c2 + (1.0 - c2)
    return np.where(c > 0.0, a2 / (np.pi * f * f), 0.0)


def visibility(n_dot_l, n_dot_v, alpha, kind: str = "height_correlated") -> np.ndarray:
    """Smith's V = G2 / (4 n.l n.v) for the GGX lobe (see the module docstring); n.l, n.v > 0."""
    nl = np.asarray(n_dot_l, dtype=np.float64)
    nv = np.asarray(n_dot_v, dtype=np.float64)
    a2 = np.asarray(alpha, dtype=np.float64) ** 2
    lam_l = np.sqrt(a2 + (1.0 - a2) * nl * nl)
    lam_v = np.sqrt(a2 + (1.0 - a2) * nv * nv)
    if kind == "height_correlated":
        return 0.5 / (nv * lam_l + nl * lam_v)
    if kind == "separable":
        return 1.0 / ((nl + lam_l) * (nv + lam_v))
    raise ValueError(f"visibility must be one of {', '.join(VISIBILITIES)}, got {kind!r}")


def importance_half_vectors(alpha, n: int) -> tuple[np.ndarray, np.ndarray]:
    """GGX half-vector importance sampling (Walter et al. 2007) of the Hammersley set, as Khronos' and
    Filament's filters write it: phi = 2 pi u, cos^2 theta = (1 - v) / (1 + (alpha^2 - 1) v), pdf(h) =
    D(h) n.h. Returns (h (n, 3) in the frame z = n, sin^2 theta) with sin^2 theta = alpha^2 v / (1 +
    (alpha^2 - 1) v) computed directly (no 1 - cos^2 cancellation for tiny lobes)."""
    u, v = hammersley(n)
    a2 = float(alpha) ** 2
    denom = 1.0 + (a2 - 1.0) * v
    sin2 = a2 * v / denom
    cos = np.sqrt((1.0 - v) / denom)
    sin = np.sqrt(sin2)
    phi = 2.0 * np.pi * u
    return np.stack([sin * np.cos(phi), sin * np.sin(phi), cos], axis=-1), sin2


def vndf_half_vectors(alpha, n: int) -> tuple[np.ndarray, np.ndarray]:
    """GGX visible-normal sampling (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT
    7(4)) of the Hammersley set as three.js' PMREM filter writes it (importanceSampleGGX_VNDF with
    r = sqrt(u), phi = 2 pi v), for the view V = n the split sum's prefilter assumes.

    With V = n the stretched view is n itself, the disc sample (t1, t2) is not warped (s = 1), and the
    half vector is normalize(alpha t1, alpha t2, sqrt(1 - r^2)): tan^2 theta = alpha^2 u / (1 - u), the
    inverse CDF of D(h) n.h. So with N = V the visible-normal density D_v(h) = G1(n) max(n.h, 0) D(h) /
    n.n = D(h) n.h is the plain half-vector density and the warp is importance_half_vectors' with u and v
    exchanged; for n a power of two the Hammersley set is symmetric under that exchange (the radical
    inverse of i < 2^m is i's m bits reversed, an involution), so both give the same directions.
    Returns (h, sin^2 theta), sin^2 theta = alpha^2 u / (1 + (alpha^2 - 1) u)."""
    u, v = hammersley(n)
    a = float(alpha)
    r = np.sqrt(u)
    phi = 2.0 * np.pi * v
    t1, t2, t3 = r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(1.0 - u, 0.0))
    h = np.stack([a * t1, a * t2, t3], axis=-1)
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    a2 = a * a
    return h, a2 * u / (1.0 + (a2 - 1.0) * u)


def half_vectors(sampling: str, alpha, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The half vectors of `sampling` ("importance" or "vndf")."""
    if sampling == "importance":
        return importance_half_vectors(alpha, n)
    if sampling == "vndf":
        return vndf_half_vectors(alpha, n)
    raise ValueError(f'sampling must be "importance" or "vndf", got {sampling!r}')
