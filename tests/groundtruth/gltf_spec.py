"""glTF 2.0's metallic-roughness BRDF written again for the tests, from the specification's text alone.

The specification (Appendix B, "Specular BRDF", "Fresnel", "Metal BRDF and Dielectric BRDF") gives
MicrofacetBRDF = G D / (4 |N.L| |N.V|) with
    D = alpha^2 chi+(N.H) / (pi ((N.H)^2 (alpha^2 - 1) + 1)^2),
    G = 2 |N.L| |N.V| chi+(H.L) chi+(H.V) / (|N.V| sqrt(alpha^2 + (1 - alpha^2)(N.L)^2)
                                             + |N.L| sqrt(alpha^2 + (1 - alpha^2)(N.V)^2)),
and its "full code":
    fresnel_w = (1 - abs(VdotH))^5
    diffuse_brdf = (1 / pi) * baseColor.rgb
    specular_brdf = D(roughness^2) * G(roughness^2) / (4 * abs(VdotN) * abs(LdotN))
    dielectric_fresnel = 0.04 + (1 - 0.04) * fresnel_w
    dielectric_brdf = mix(diffuse_brdf, specular_brdf, dielectric_fresnel)
    metal_fresnel = baseColor.rgb + (1 - baseColor.rgb) * fresnel_w
    metal_brdf = metal_fresnel * specular_brdf
    material = mix(dielectric_brdf, metal_brdf, metallic)
with mix(a, b, t) = a (1 - t) + b t. Here G, not the visibility V = G / (4 |N.L| |N.V|), is what is written out,
so that this copy shares no line with groundtruth/exact/gltf_brdf.py.
"""

from __future__ import annotations

import numpy as np

MIN_ALPHA = 0.045 ** 2  # the contract's clamp, restated


def mix(a, b, t):
    return a * (1.0 - t) + b * t


def spec_f(base_color, metallic: float, roughness: float, n: np.ndarray, v: np.ndarray, l: np.ndarray,
           g_form: str = "correlated") -> np.ndarray:
    """f(v, l) (..., 3) for unit vectors broadcast against each other; `g_form = "separable"` is the pre-2.0.1
    product G1(L) G1(V) (a wrong variant for negative controls)."""
    alpha = max(roughness * roughness, MIN_ALPHA)
    a2 = alpha * alpha
    h = l + v
    h = h / np.maximum(np.linalg.norm(h, axis=-1, keepdims=True), 1e-300)
    nl, nv, nh = np.sum(n * l, -1), np.sum(n * v, -1), np.sum(n * h, -1)
    hl, hv = np.sum(h * l, -1), np.sum(h * v, -1)
    d = a2 * (nh > 0) / (np.pi * (nh * nh * (a2 - 1.0) + 1.0) ** 2)
    sl = np.sqrt(a2 + (1.0 - a2) * nl * nl)
    sv = np.sqrt(a2 + (1.0 - a2) * nv * nv)
    if g_form == "correlated":
        g = 2.0 * np.abs(nl) * np.abs(nv) * (hl > 0) * (hv > 0) / (np.abs(nv) * sl + np.abs(nl) * sv)
    else:
        g = (2.0 * np.abs(nl) * (hl > 0) / (np.abs(nl) + sl)) * (2.0 * np.abs(nv) * (hv > 0) / (np.abs(nv) + sv))
    specular_brdf = (d * g / (4.0 * np.abs(nv) * np.abs(nl)))[..., None]
    fresnel_w = ((1.0 - np.abs(hv)) ** 5)[..., None]
    base = np.asarray(base_color, dtype=np.float64)
    diffuse_brdf = base / np.pi
    dielectric_brdf = mix(diffuse_brdf, specular_brdf, 0.04 + (1.0 - 0.04) * fresnel_w)
    metal_brdf = (base + (1.0 - base) * fresnel_w) * specular_brdf
    return mix(dielectric_brdf, metal_brdf, metallic)


def frame(mu: float) -> tuple[np.ndarray, np.ndarray]:
    """(n, v) with n = +z and v at n.v = mu in the xz-plane."""
    return np.array([0.0, 0.0, 1.0]), np.array([np.sqrt(1.0 - mu * mu), 0.0, mu])


def hemisphere_grid(n_theta: int = 200, n_phi: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """(directions (N, 3), solid-angle weights (N,)) over the upper hemisphere about +z: Gauss-Legendre in cos theta,
    the midpoint rule in phi. Accurate for lobes wider than ~0.1 rad (roughness >= 0.5)."""
    x, w = np.polynomial.legendre.leggauss(n_theta)
    c = 0.5 * (x + 1.0)
    wc = 0.5 * w
    phi = (np.arange(n_phi) + 0.5) * (2.0 * np.pi / n_phi)
    s = np.sqrt(1.0 - c * c)
    d = np.stack([np.outer(s, np.cos(phi)), np.outer(s, np.sin(phi)), np.repeat(c[:, None], n_phi, 1)], -1)
    return d.reshape(-1, 3), np.repeat(wc * (2.0 * np.pi / n_phi), n_phi)


def mc_albedo(base_color, metallic: float, roughness: float, mu: float, samples: int, seed: int,
              g_form: str = "correlated", radiance=None) -> tuple[np.ndarray, np.ndarray]:
    """(mean, standard error) (3,) of int f(v, l) (n.l) L(l) dl over n.l > 0 (L = 1 unless `radiance`(l) is given),
    by Monte Carlo: half the samples cosine-weighted, half the half vector from D (n.h) (tan^2 theta_h =
    alpha^2 u / (1 - u)), combined by the balance heuristic (the one-sample mixture density)."""
    rng = np.random.default_rng(seed)
    alpha = max(roughness * roughness, MIN_ALPHA)
    n, v = frame(mu)
    u1, u2, pick = rng.random(samples), rng.random(samples), rng.random(samples) < 0.5
    # cosine-weighted l
    r = np.sqrt(u1)
    l_cos = np.stack([r * np.cos(2 * np.pi * u2), r * np.sin(2 * np.pi * u2), np.sqrt(1.0 - u1)], -1)
    # GGX half vector, reflected
    t2 = alpha * alpha * u1 / np.maximum(1.0 - u1, 1e-300)
    ct = 1.0 / np.sqrt(1.0 + t2)
    st = np.sqrt(np.maximum(1.0 - ct * ct, 0.0))
    h = np.stack([st * np.cos(2 * np.pi * u2), st * np.sin(2 * np.pi * u2), ct], -1)
    l_ggx = 2.0 * np.sum(h * v, -1, keepdims=True) * h - v
    l = np.where(pick[:, None], l_cos, l_ggx)
    nl = l[:, 2]
    hh = l + v
    hh = hh / np.maximum(np.linalg.norm(hh, axis=-1, keepdims=True), 1e-300)
    nh, vh = hh[:, 2], np.sum(hh * v, -1)
    a2 = alpha * alpha
    d = a2 * (nh > 0) / (np.pi * (nh * nh * (a2 - 1.0) + 1.0) ** 2)
    pdf = 0.5 * np.maximum(nl, 0.0) / np.pi + 0.5 * d * nh / (4.0 * np.maximum(vh, 1e-300))
    ok = (nl > 0) & (pdf > 0)
    val = np.zeros((samples, 3))
    f = spec_f(base_color, metallic, roughness, n, v, l[ok], g_form)
    lum = 1.0 if radiance is None else radiance(l[ok])
    val[ok] = f * (nl[ok] / pdf[ok])[:, None] * lum
    return val.mean(0), val.std(0) / np.sqrt(samples)
