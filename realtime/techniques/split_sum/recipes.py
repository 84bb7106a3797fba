"""Each engine's published split-sum choices, as data: the defaults `[realtime.split_sum] recipe` picks.

Karis' split sum (Real Shading in Unreal Engine 4, SIGGRAPH 2013 course notes) lights a GGX lobe from an
environment with two tables: a cube chain prefiltered with the lobe under n = v = r, read at a level chosen
by roughness, and the DFG pair (A, B) indexed by (n.v, roughness) with specular = prefiltered (F0 A + B).
Every engine makes the same approximation with different choices; a recipe is one engine's choices:

    sampling       "importance": GGX half-vector importance sampling with filtered importance sampling
                   (Krivanek & Colbert 2008); "vndf": GGX visible-normal sampling (Heitz 2018)
    samples        samples per prefiltered texel
    fis_bias       levels added to filtered importance sampling's 0.5 log2(Omega_s / Omega_p)
    lod_mapping    roughness <-> mip level ("linear", "filament", "threejs", "babylon"; "per_material":
                   one level prefiltered for each roughness in the scene, no interpolation across roughness)
    size           face size of the prefiltered chain's base level
    lut_size, lut_samples, lut_precision   the DFG table
    multiscatter   Fdez-Aguera 2019's compensation of the energy single scattering loses

Each value carries its source beside it. `custom` takes no defaults: every parameter is given.
"""

from __future__ import annotations

#: the parameters a recipe sets (the fields of declaration.SplitSum other than `recipe`)
PARAMETERS = ("sampling", "samples", "fis_bias", "lod_mapping", "size", "lut_size", "lut_samples", "lut_precision",
              "multiscatter")

RECIPES: dict[str, dict[str, object]] = {
    # KhronosGroup/glTF-Sample-Viewer with glTF-IBL-Sampler: GGX importance sampling with filtered importance
    # sampling, 1024 samples, a 256 cube, lod = roughness (levels - 1), a 1024^2 LUT of 512 samples, and
    # Fdez-Aguera's multiple scattering in getIBLGGXFresnel
    "khronos": {"sampling": "importance", "samples": 1024, "fis_bias": 0.0, "lod_mapping": "linear", "size": 256,
                "lut_size": 1024, "lut_samples": 512, "lut_precision": "f16", "multiscatter": True},
    # google/filament cmgen (libs/ibl): GGX importance sampling with filtered importance sampling and a +1 level
    # bias (K = 4), 1024 samples, lod = maxLod r (2 - r), the DFG table of `--size`
    "filament": {"sampling": "importance", "samples": 1024, "fis_bias": 1.0, "lod_mapping": "filament", "size": 256,
                 "lut_size": 128, "lut_samples": 512, "lut_precision": "f16", "multiscatter": True},
    # mrdoob/three.js r18x PMREMGenerator: GGX VNDF sampling, 256 samples, cube mips down to 16, a 16 x 16 RG16F
    # DFG table with multiple scattering
    "threejs": {"sampling": "vndf", "samples": 256, "fis_bias": 0.0, "lod_mapping": "threejs", "size": 256,
                "lut_size": 16, "lut_samples": 512, "lut_precision": "f16", "multiscatter": True},
    # BabylonJS hdrFiltering: GGX importance sampling on load, 4096 samples (quality 8 ... 4096), lod from
    # alpha = 2^(lod / 0.8) / width
    "babylon": {"sampling": "importance", "samples": 4096, "fis_bias": 0.0, "lod_mapping": "babylon", "size": 256,
                "lut_size": 256, "lut_samples": 512, "lut_precision": "f16", "multiscatter": True},
}
NAMES = (*RECIPES, "custom")
#: a parameter left to the recipe
FROM_RECIPE = "recipe"


def resolve(params) -> dict[str, object]:
    """The settings a `[realtime.split_sum]` table runs with: its recipe's, each given parameter instead."""
    base = RECIPES.get(params.recipe, {})
    out = {"recipe": params.recipe}
    for key in PARAMETERS:
        value = getattr(params, key)
        out[key] = base[key] if value == FROM_RECIPE else value
    return out
