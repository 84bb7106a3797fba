"""Roughness <-> level of the split sum's prefiltered chain, as each engine maps them.

A chain is a list of levels, each a cube of its own face size prefiltered with the GGX lobe of its own
roughness (chain.py). The shader reads an object's radiance at the continuous level index `lod(r)`:
bilinear in the two levels around it, linear between them (what textureLod does on a mip chain). The
roughness a level is prefiltered with is the inverse of the same mapping, so a material whose roughness
is a level's reads that level alone. Level 0 holds roughness 0 (the source, sharpened to the material's
minimum alpha) in every mapping, as every engine writes it: Khronos and Filament by their formulas,
three.js by copying its source (PMREMGenerator: level 0 is the cube itself), Babylon by setting alpha = 0
for lod 0 (HDRFiltering._prefilterInternal).

    linear      lod = r (n - 1)                             Khronos glTF-Sample-Viewer ibl.glsl,
                                                            getIBLRadianceGGX: roughness * (u_MipCount - 1);
                                                            level k: r = k / (n - 1) (ibl_sampler.js
                                                            cubeMapToGGX)
    filament    lod = (n - 1) r (2 - r)                     Filament surface_light_indirect.fs,
                                                            perceptualRoughnessToLod; level k:
                                                            r = 1 - sqrt(1 - k / (n - 1)) (cmgen.cpp and
                                                            IBLPrefilterContext.cpp lodToPerceptualRoughness)
    threejs     lod = log2(size) - clamp(m(r), -2, log2(size))   three.js cube_uv_reflection_fragment,
                m(r) = the piecewise roughnessToMip below,  textureCubeUV: m is log2 of a level's texel
                levels below 16 texels stay 16 texels wide  count, down to -2 for the six extra levels of
                                                            PMREMGenerator at LOD_MIN = 4 (16 texels)
    babylon     lod = 0.8 log2(size alpha(r))               Babylon pbrIBLFunctions getLodFromAlphaG times
                                                            vReflectionMicrosurfaceInfos.y (lodGenerationScale
                                                            0.8, offset 0); level k: alpha = 2^(k / 0.8) / size
                                                            (HDRFiltering._prefilterInternal)
    per_material  one level per distinct roughness of the scene, each at the chain's base size: no
                interpolation across roughness (the exact counterpart of the mapped chains)

n is the number of levels of the chain, `size` its base face size; lods are clamped to [0, n - 1].
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from scenes.model.materials import PBR_MIN_ALPHA

MAPPINGS = ("linear", "filament", "threejs", "babylon", "per_material")

# three.js' roughnessToMip (cube_uv_reflection_fragment.glsl.js, cubeUV_r* / cubeUV_m*): piecewise linear
# through (roughness, mip) = (1, -2), (0.8, -1), (0.4, 2), (0.305, 3), (0.21, 4), then -2 log2(1.16 r)
THREEJS_KNOTS = ((1.0, -2.0), (0.8, -1.0), (0.4, 2.0), (0.305, 3.0), (0.21, 4.0))
THREEJS_LOG_SCALE = 1.16  # "1.16 = 1.79^0.25"
#: the last extra level's mip (cubeUV_m0) and the face size below which three.js adds no smaller level
THREEJS_MIN_MIP = -2.0
THREEJS_MIN_TILE = 16
#: Babylon's lodGenerationScale and lodGenerationOffset (HDRFiltering, BaseTexture defaults)
BABYLON_SCALE = 0.8
BABYLON_OFFSET = 0.0


@dataclass(frozen=True)
class Level:
    """One level of a chain: the roughness it is prefiltered with and its face size."""
    roughness: float
    size: int


def _log2_int(x: int, what: str) -> int:
    if x < 1 or x & (x - 1):
        raise ValueError(f"{what} must be a power of two, got {x}")
    return x.bit_length() - 1


def threejs_roughness_to_mip(r: float) -> float:
    """three.js' roughnessToMip (see THREEJS_KNOTS)."""
    for (r_hi, m_hi), (r_lo, m_lo) in zip(THREEJS_KNOTS, THREEJS_KNOTS[1:], strict=False):
        if r >= r_lo:
            return (r_hi - r) * (m_lo - m_hi) / (r_hi - r_lo) + m_hi
    return -2.0 * math.log2(THREEJS_LOG_SCALE * max(r, 1e-30))


def threejs_mip_to_roughness(m: float) -> float:
    """Its inverse on the mips it reaches: each linear piece solved for r, and r = 2^(-m/2) / 1.16 on the
    logarithmic one. (roughnessToMip jumps from 4 at r = 0.21 to 4.075 just below it: mips in (4, 4.075)
    are never read; this returns 0.21 for them.)"""
    for (r_hi, m_hi), (r_lo, m_lo) in zip(THREEJS_KNOTS, THREEJS_KNOTS[1:], strict=False):
        if m <= m_lo:
            return r_hi - (m - m_hi) * (r_hi - r_lo) / (m_lo - m_hi)
    return min(2.0 ** (-m / 2.0) / THREEJS_LOG_SCALE, THREEJS_KNOTS[-1][0])


def n_levels(mapping: str, size: int, min_size: int) -> int:
    """Levels of a mapped chain of base face `size` whose smallest level is `min_size` texels wide (three.js:
    its levels down to mip -2, those below `min_size` kept at `min_size`)."""
    lmax = _log2_int(size, "size")
    lmin = min(_log2_int(min_size, "min_size"), lmax)
    if mapping == "threejs":
        return lmax - int(THREEJS_MIN_MIP) + 1
    if mapping in ("linear", "filament", "babylon"):
        return lmax - lmin + 1
    raise ValueError(f"no mapped chain for lod_mapping {mapping!r}")


def lod(mapping: str, roughness: float, size: int, levels: int) -> float:
    """The continuous level index at which `mapping` reads roughness r, clamped to [0, levels - 1]."""
    r = float(roughness)
    top = float(levels - 1)
    if mapping == "linear":
        x = r * top
    elif mapping == "filament":
        x = top * r * (2.0 - r)
    elif mapping == "threejs":
        lmax = float(_log2_int(size, "size"))
        x = lmax - min(max(threejs_roughness_to_mip(r), THREEJS_MIN_MIP), lmax)
    elif mapping == "babylon":
        alpha = max(r * r, PBR_MIN_ALPHA)
        x = math.log2(size * alpha) * BABYLON_SCALE + BABYLON_OFFSET
    else:
        raise ValueError(f"no continuous lod for lod_mapping {mapping!r}")
    return min(max(x, 0.0), top)


def level_roughness(mapping: str, k: int, size: int, levels: int) -> float:
    """The roughness level k of a `mapping` chain is prefiltered with: the inverse of `lod` (0 at k = 0)."""
    if not 0 <= k < levels:
        raise ValueError(f"level {k} outside [0, {levels - 1}]")
    if k == 0:
        return 0.0
    x = k / (levels - 1)
    if mapping == "linear":
        return x
    if mapping == "filament":
        return 1.0 - math.sqrt(max(1.0 - x, 0.0))
    if mapping == "threejs":
        return threejs_mip_to_roughness(_log2_int(size, "size") - k)
    if mapping == "babylon":
        return math.sqrt(2.0 ** ((k - BABYLON_OFFSET) / BABYLON_SCALE) / size)
    raise ValueError(f"no levels for lod_mapping {mapping!r}")


def chain_levels(mapping: str, size: int, min_size: int, roughnesses: Iterable[float] = ()) -> tuple[Level, ...]:
    """The levels of the chain `mapping` builds: a mapped chain's levels (sizes size >> k, never below
    `min_size`), or for per_material one level of face `size` per distinct roughness, in increasing order."""
    if mapping == "per_material":
        rs = sorted({float(r) for r in roughnesses})
        if not rs:
            raise ValueError("per_material needs the scene's roughnesses")
        return tuple(Level(r, size) for r in rs)
    count = n_levels(mapping, size, min_size)
    floor = min(min_size, size)
    return tuple(Level(level_roughness(mapping, k, size, count), max(size >> k, floor)) for k in range(count))


def read_levels(mapping: str, roughness: float, levels: tuple[Level, ...], size: int) -> tuple[int, int, float]:
    """(k0, k1, t): an object of `roughness` reads (1 - t) level k0 + t level k1."""
    if mapping == "per_material":
        for k, level in enumerate(levels):
            if level.roughness == float(roughness):
                return k, k, 0.0
        raise ValueError(f"roughness {roughness} has no level of its own in the per_material chain")
    x = lod(mapping, roughness, size, len(levels))
    k0 = int(math.floor(x))
    k1 = min(k0 + 1, len(levels) - 1)
    return k0, k1, x - k0
