"""Each engine's published split-sum choices, as data: the defaults `[realtime.split_sum] recipe` picks.

Karis' split sum (Real Shading in Unreal Engine 4, SIGGRAPH 2013 course notes) lights a GGX lobe from an
environment with two tables: a cube chain prefiltered with the lobe under n = v = r, read at a level chosen
by roughness, and the DFG pair (A, B) indexed by (n.v, roughness) with specular = prefiltered (F0 A + B).
Every engine makes the same approximation with different choices; a recipe is one engine's choices:

    sampling       "importance": GGX half-vector importance sampling; "vndf": GGX visible-normal sampling
                   (Heitz 2018), which with n = v draws the same density (ggx.py)
    samples        samples per prefiltered texel
    double_samples the sample count doubles at each level from level 2 on (Filament's cmgen)
    fis_bias       levels added to filtered importance sampling's 0.5 log2(Omega_s / Omega_p)
                   (Krivanek & Colbert 2008; samples.py)
    lod_mapping    roughness <-> level ("linear", "filament", "threejs", "babylon"; "per_material": one
                   level prefiltered for each roughness in the scene, no interpolation across roughness;
                   mappings.py)
    size           face size of the prefiltered chain's base level
    min_size       face size of its smallest level (three.js: its roughest levels stay this size)
    lut_size, lut_samples, lut_precision   the DFG table (dfg.py)
    visibility     the Smith term of the DFG table: "height_correlated" (every engine's table) or
                   "separable" (glTF 2.0 Appendix B as written)
    multiscatter   the compensation of the energy single scattering loses (ibl_fresnel.py): "none",
                   "fdez_aguera" (Khronos), "threejs", "filament" (Filament, Babylon)

Each value carries its source beside it: the peer's repository, file and function (the code read to
fix it). What a recipe does not reproduce is said in docs/techniques.md. `custom` takes no defaults:
every parameter is given.
"""

from __future__ import annotations

import math

#: the parameters a recipe sets (the fields of declaration.SplitSum other than `recipe`)
PARAMETERS = ("sampling", "samples", "double_samples", "fis_bias", "lod_mapping", "size", "min_size", "lut_size",
              "lut_samples", "lut_precision", "visibility", "multiscatter")

#: Khronos' filter computes lod = 0.5 log2(6 w^2 / (N pdf)) (KhronosGroup/glTF-Sample-Viewer
#: source/shaders/ibl_filtering.frag computeLod; KhronosGroup/glTF-IBL-Sampler lib/source/shaders/filter.frag
#: line 298 at 08fa122): Krivanek & Colbert's 0.5 log2(Omega_s / Omega_p) without Omega_p's 4 pi, i.e.
#: 0.5 log2(4 pi) = 1.826 levels coarser
KHRONOS_FIS_BIAS = 0.5 * math.log2(4.0 * math.pi)

RECIPES: dict[str, dict[str, object]] = {
    "khronos": {
        "sampling": "importance",  # ibl_filtering.frag getImportanceSample: GGX(xi, roughness), Walter et al.
        "samples": 1024,  # glTF-Sample-Viewer source/ibl_sampler.js: this.ggxSampleCount = 1024
        "double_samples": False,  # ibl_sampler.js cubeMapToGGX: one count for every level
        "fis_bias": KHRONOS_FIS_BIAS,  # computeLod (above) with this.lodBias = 0.0
        "lod_mapping": "linear",  # ibl.glsl getIBLRadianceGGX: lod = roughness * (u_MipCount - 1);
        # ibl_sampler.js cubeMapToGGX: roughness = level / (mipmapLevels - 1)
        "size": 256,  # ibl_sampler.js: this.textureSize = 256
        "min_size": 16,  # ibl_sampler.js: this.lowestMipLevel = 4, mipmapLevels = log2(256) + 1 - 4 (256 ... 16)
        "lut_size": 1024,  # ibl_sampler.js: this.lutResolution = 1024
        "lut_samples": 512,  # ibl_sampler.js sampleLut: u_sampleCount = 512
        "lut_precision": "f16",  # ibl_sampler.js: preferredFormat = "HALF_FLOAT" (RGBA16F render target)
        "visibility": "height_correlated",  # ibl_filtering.frag LUT(): V_SmithGGXCorrelated
        "multiscatter": "fdez_aguera",  # source/Renderer/shaders/ibl.glsl getIBLGGXFresnel (Fdez-Aguera 2019)
    },
    "filament": {
        "sampling": "importance",  # google/filament libs/ibl/src/CubemapIBL.cpp hemisphereImportanceSampleDggx
        "samples": 1024,  # tools/cmgen/src/cmgen.cpp: g_num_samples = 1024 (--ibl-samples)
        "double_samples": True,  # cmgen.cpp iblRoughnessPrefilter: "if (level >= 2) numSamples *= 2"
        "fis_bias": 1.0,  # CubemapIBL.cpp roughnessFilter: lod = log4(Omega_s) - log4(Omega_p) + log4(K), K = 4
        "lod_mapping": "filament",  # shaders/src/surface_light_indirect.fs perceptualRoughnessToLod:
        # iblRoughnessOneLevel * r (2 - r); cmgen.cpp lodToPerceptualRoughness, its inverse, per level
        "size": 256,  # cmgen.cpp: IBL_DEFAULT_SIZE = 256
        "min_size": 16,  # cmgen.cpp: --ibl-min-lod-size "Minimum LOD size [default: 16]"
        "lut_size": 128,  # filament/src/details/DFG.h: FILAMENT_DFG_LUT_SIZE 128
        "lut_samples": 1024,  # CubemapIBL.cpp DFG: dfvFunction(NoV, linear_roughness, 1024)
        "lut_precision": "f16",  # filament/src/details/DFG.cpp: TextureFormat::RGB16F
        "visibility": "height_correlated",  # CubemapIBL.cpp Visibility: "Height-correlated GGX"
        "multiscatter": "filament",  # shaders/src/shading_lit.fs getEnergyCompensationPixelParams:
        # energyCompensation = 1 + f0 (1 / dfg.y - 1), on by default
    },
    "threejs": {
        "sampling": "vndf",  # mrdoob/three.js src/extras/PMREMGenerator.js _getGGXShader:
        # importanceSampleGGX_VNDF (Heitz 2018), V = N
        "samples": 256,  # PMREMGenerator.js: const GGX_SAMPLES = 256
        "double_samples": False,  # one GGX_SAMPLES for every level
        "fis_bias": 0.0,  # none in three.js: each level reads the previous one at its own resolution
        # (_applyGGXFilter); here every level reads the environment with filtered importance sampling
        "lod_mapping": "threejs",  # src/renderers/shaders/ShaderChunk/cube_uv_reflection_fragment.glsl.js
        # roughnessToMip, textureCubeUV
        "size": 256,  # PMREMGenerator.js fromScene: options.size = 256
        "min_size": 16,  # PMREMGenerator.js: LOD_MIN = 4 (16 texels), EXTRA_LODS = 6 at that size
        "lut_size": 16,  # src/nodes/functions/BSDF/DFGApprox.js (r184 ... r186): "Resolution: 16x16"
        "lut_samples": 4096,  # utils/generateDFGLUT.js: SAMPLE_COUNT = 4096
        "lut_precision": "f16",  # src/renderers/shaders/DFGLUTData.js: RGFormat, HalfFloatType
        "visibility": "height_correlated",  # generateDFGLUT.js V_SmithGGXCorrelated
        "multiscatter": "threejs",  # ShaderChunk/lights_physical_pars_fragment.glsl.js computeMultiscattering
    },
    "babylon": {
        "sampling": "importance",  # BabylonJS packages/dev/core/src/Shaders/ShadersInclude/hdrFilteringFunctions.fx
        # radiance(): hemisphereImportanceSampleDggx
        "samples": 4096,  # packages/dev/core/src/Materials/Textures/Filtering/hdrFiltering.ts: quality = 4096
        "double_samples": False,  # NUM_SAMPLES for every level
        "fis_bias": 1.0,  # hdrFilteringFunctions.fx radiance(): l = log4(omegaS) - log4(omegaP) + log4(K), K = 4
        "lod_mapping": "babylon",  # pbrIBLFunctions getLodFromAlphaG, x lodGenerationScale 0.8;
        # hdrFiltering.ts _prefilterInternal: alpha = 2^(lod / 0.8) / width, 0 at lod 0
        "size": 256,  # the filtered cube's own width (hdrFiltering.ts); 256 for a typical .env
        "min_size": 1,  # hdrFiltering.ts: mipmapsCount = ILog2(width) + 1, down to 1 texel
        "lut_size": 256,  # packages/dev/core/src/Misc/brdfTextureTools.ts _environmentBRDFBase64Texture: 256^2 PNG
        "lut_samples": 1024,  # not published (the table ships as a PNG); Filament's count
        "lut_precision": "u8",  # that PNG: 8 bits per channel (RGBD-encoded; modelled as unorm8)
        "visibility": "height_correlated",  # brdfTextureTools.ts: "MS-BRDF Height Correlated BRDF"
        "multiscatter": "filament",  # pbrBRDFFunctions.fx getEnergyConservationFactor: 1 + F0 (1 / brdf.y - 1)
    },
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
