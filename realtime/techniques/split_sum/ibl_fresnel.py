"""The split sum's directional albedo F_ibl(F0) of the GGX lobe from the DFG pair (A, B), with each engine's
compensation of the energy that single scattering loses: the numpy mirror of split_sum_fresnel in
glossy_split_sum.glsl. The shaded specular is F_ibl times the prefiltered radiance.

    none          F0 A + B                                         Karis 2013
    fdez_aguera   Fdez-Aguera 2019 ("A Multiple-Scattering Microfacet Model for Real-Time Image-based
                  Lighting", JCGT 8(1)) as Khronos' glTF-Sample-Viewer writes it (ibl.glsl,
                  getIBLGGXFresnel, specularWeight 1): with the roughness-dependent Fresnel
                      Fr = max(1 - r, F0) - F0,  k_S = F0 + Fr (1 - n.v)^5,  FssEss = k_S A + B,
                      Ems = 1 - (A + B),  F_avg = F0 + (1 - F0) / 21,
                      F_ibl = FssEss + Ems FssEss F_avg / (1 - F_avg Ems)
    threejs       three.js' computeMultiscattering (lights_physical_pars_fragment): the same without the
                  roughness-dependent Fresnel, FssEss = F0 A + B, F_ibl = FssEss + FssEss F_avg Ems /
                  (1 - Ems F_avg)
    filament      Filament's and Babylon's energy compensation (Filament surface_shading / Babylon
                  getEnergyConservationFactor): F_ibl = (F0 A + B) (1 + F0 (1 / (A + B) - 1))

For F0 = 1 the three compensations give exactly 1 (a white furnace keeps all its energy: Ess + Ems = 1),
and `none` gives A + B.
"""

from __future__ import annotations

import numpy as np

MULTISCATTER = ("none", "fdez_aguera", "threejs", "filament")
#: the code the shader's SPLIT_SUM_MULTISCATTER define takes for each
MULTISCATTER_CODE = {name: i for i, name in enumerate(MULTISCATTER)}


def ibl_fresnel(a, b, f0, roughness, n_dot_v, multiscatter: str = "none") -> np.ndarray:
    """F_ibl for DFG pairs (a, b) (broadcast) and reflectance f0 (scalar or RGB on the last axis)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    f0 = np.asarray(f0, dtype=np.float64)
    if f0.ndim:  # RGB: the table's values apply to each channel
        a, b = a[..., None], b[..., None]
    single = f0 * a + b
    if multiscatter == "none":
        return single
    ess = a + b
    ems = 1.0 - ess
    f_avg = f0 + (1.0 - f0) / 21.0
    if multiscatter == "fdez_aguera":
        r = np.asarray(roughness, dtype=np.float64)
        nv = np.asarray(n_dot_v, dtype=np.float64)
        if f0.ndim:
            r, nv = r[..., None], nv[..., None]
        fr = np.maximum(1.0 - r, f0) - f0
        fss_ess = (f0 + fr * (1.0 - nv) ** 5) * a + b
        return fss_ess + ems * fss_ess * f_avg / (1.0 - f_avg * ems)
    if multiscatter == "threejs":
        return single + single * f_avg * ems / (1.0 - ems * f_avg)
    if multiscatter == "filament":
        return single * (1.0 + f0 * (1.0 / ess - 1.0))
    raise ValueError(f"multiscatter must be one of {', '.join(MULTISCATTER)}, got {multiscatter!r}")
