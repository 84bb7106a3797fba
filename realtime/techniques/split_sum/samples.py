"""The prefilter's sample sets: the directions a texel of the split sum's GGX chain reads, and the level of
the source each reads them at, computed once on the host in float64.

Karis' split sum prefilters the environment with the GGX lobe under n = v = r: a texel of direction n holds

    P(n) = int L(l) D(h) (n.l) dl / int D(h) (n.l) dl,    h = normalize(n + l), over n.l > 0,

estimated as every engine does (Karis 2013; Khronos' glTF-IBL-Sampler filterColor, Filament's
CubemapIBL::roughnessFilter, Babylon's radiance(), three.js' PMREM GGX filter): half vectors h drawn
with density D(h) n.h (ggx.py), l = reflect(-n, h) = 2 (n.h) h - n, samples with n.l <= 0 dropped, and

    P(n) ~ sum L(l) n.l / sum n.l.

With v = n, v.h = n.h, so a sample's density over l is pdf(l) = D(h) n.h / (4 v.h) = D(h) / 4.
Filtered importance sampling (Krivanek & Colbert 2008) reads each sample at the source's mip level whose
texel matches the solid angle the sample stands for:

    lod = 0.5 log2(Omega_s / Omega_p) + bias,  Omega_s = 1 / (N pdf(l)),  Omega_p = 4 pi / (6 w^2),

N the number of samples drawn (dropped ones included, as the engines count them) and w the source
cube's base face size; the shader adds the bias and clamps to the source's levels.

Each row: (l.x, l.y, 1 - l.z, 0.5 log2(Omega_s / Omega_p)) in the frame z = n. 1 - l.z = 2 sin^2 theta_h
is kept apart so that a lobe of alpha ~ 2e-3 (roughness 0, clamped) keeps its shape in float32; the
shader's weight n.l is 1 minus it.
"""

from __future__ import annotations

import math

import numpy as np

from realtime.techniques.split_sum.ggx import alpha_of, half_vectors, ndf


def prefilter_samples(roughness: float, samples: int, source_size: int, sampling: str = "importance") -> np.ndarray:
    """(k, 4) float64 rows (see the module docstring) of the `samples` drawn for `roughness`, the k <=
    samples with n.l > 0."""
    if samples < 1:
        raise ValueError(f"samples must be >= 1, got {samples}")
    if source_size < 1:
        raise ValueError(f"source_size must be >= 1, got {source_size}")
    alpha = float(alpha_of(roughness))
    h, sin2 = half_vectors(sampling, alpha, samples)
    cos = h[:, 2]
    one_minus_lz = 2.0 * sin2  # l.z = 2 cos^2 - 1
    keep = one_minus_lz < 1.0
    lx, ly = 2.0 * cos * h[:, 0], 2.0 * cos * h[:, 1]
    pdf = ndf(cos, alpha) / 4.0
    log2_omega_p = math.log2(4.0 * math.pi / (6.0 * source_size * source_size))
    half_log2_ratio = 0.5 * (-math.log2(samples) - np.log2(pdf) - log2_omega_p)
    rows = np.stack([lx, ly, one_minus_lz, half_log2_ratio], axis=-1)
    return rows[keep]


def sample_counts(n_levels: int, samples: int, double_from: int | None) -> list[int]:
    """Samples per level: `samples`, doubled at each level from `double_from` on (Filament's cmgen doubles
    them from level 2: "as the filter gets wider ... 4x less work per level"); None: the same for all."""
    out = []
    n = samples
    for k in range(n_levels):
        if double_from is not None and k >= double_from:
            n *= 2
        out.append(n)
    return out
