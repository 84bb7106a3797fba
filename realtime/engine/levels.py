"""Which mip level the paper's method reads, and the LOD of a glossy lookup (pure functions).

Level selection (docs/contract.md section 3, step 2): a fixed `face_size` s, or `"auto"`: s linear in the
object's distance from the camera, from 64 at `AUTO_NEAR` down to 8 at `AUTO_FAR`, snapped to the
nearest power of two in log2 (the paper picks coarser levels for distant objects).
"""

from __future__ import annotations

import math

AUTO_NEAR, AUTO_FAR = 2.0, 16.0  # scene units (builtin meshes fit in the unit sphere)
AUTO_SIZES = (64, 8)


def auto_face_size(distance: float, base_size: int) -> int:
    t = min(max((distance - AUTO_NEAR) / (AUTO_FAR - AUTO_NEAR), 0.0), 1.0)
    s = AUTO_SIZES[0] + t * (AUTO_SIZES[1] - AUTO_SIZES[0])
    return min(base_size, 2 ** round(math.log2(s)))


def select_face_size(face_size: int | str, distance: float, base_size: int) -> int:
    return auto_face_size(distance, base_size) if face_size == "auto" else int(face_size)


def level_of(face_size: int, base_size: int) -> int:
    """Mip level index of a face size in the chain that starts at base_size (level 0)."""
    return int(round(math.log2(base_size / face_size)))


def mcguire_offset(face_size: int, exponent: float) -> float:
    """McGuire et al. 2013: a cosine-power lobe of exponent N covers 2 pi / (N + 1) sr, so the LOD
    above level(s) is log2(s sqrt(3)) - 0.5 log2(N + 1), never negative."""
    return max(0.0, math.log2(face_size * math.sqrt(3.0)) - 0.5 * math.log2(exponent + 1.0))


def glossy_lod_unclamped(face_size: int, base_size: int, lod_bias: float, mapping: str, exponent: float) -> float:
    """level(s) + offset(N) + bias before `glossy_lod` clamps it to the cube's chain: a 2D
    parameterization adds its own solid-angle offset first and clamps to its own chain (env_map.glsl)."""
    offset = mcguire_offset(face_size, exponent) if mapping == "mcguire" else 0.0
    return level_of(face_size, base_size) + offset + lod_bias


def glossy_lod(face_size: int, base_size: int, lod_bias: float, mapping: str, exponent: float) -> float:
    """The LOD of the paper's glossy lookup: level(s) + offset(N) + bias (`glossy_lod_unclamped`, the
    only place the formula lives; offset 0 for the paper's mapping, `mcguire_offset` for McGuire's),
    clamped to [0, log2(base)]. The shader receives it as the uniform `glossy_lod`
    (realtime/techniques/box/glossy_box.py)."""
    unclamped = glossy_lod_unclamped(face_size, base_size, lod_bias, mapping, exponent)
    return min(max(unclamped, 0.0), math.log2(base_size))


#: texels per lobe width at which a prefiltered chain is read: the texel spacing 2/w (radians, at a
#: face centre) is at most half the lobe's width sigma = 1/sqrt(N) (cos^N a ~ exp(-N a^2 / 2)), so
#: bilinear interpolation of the (smooth) convolved radiance errs by O((spacing / sigma)^2 / 8) < 4%
PREFILTER_TEXELS_PER_SIGMA = 2.0
#: never coarser than this face size (an N = 0 lobe is a hemisphere: 1x1 faces would hold 6 values)
PREFILTER_MIN_FACE = 8


def prefiltered_lod(face_size: int, base_size: int, exponent: float) -> float:
    """The LOD at which a chain prefiltered with exponent N is read: the level whose face size is
    w = 2 PREFILTER_TEXELS_PER_SIGMA sqrt(N) (at least PREFILTER_MIN_FACE), never finer than the
    selected face size s. Finer levels than that hold no more information (the radiance is already
    convolved) and cost 4x per level to prefilter."""
    w = max(float(PREFILTER_MIN_FACE), 2.0 * PREFILTER_TEXELS_PER_SIGMA * math.sqrt(max(exponent, 0.0)))
    lobe_level = math.log2(base_size / w)
    max_lod = math.log2(base_size)
    return min(max(lobe_level, float(level_of(face_size, base_size)), 0.0), max_lod)
