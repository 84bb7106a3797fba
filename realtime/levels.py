"""Which mip level the paper's method reads, and the LOD of a glossy lookup (pure functions).

Level selection (design.md section 3, step 2): a fixed `face_size` s, or `"auto"`: s linear in the
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


def glossy_lod(face_size: int, base_size: int, lod_bias: float, mapping: str, exponent: float) -> float:
    """The LOD textureLod receives (the same formula as shade.frag), clamped to the chain."""
    offset = mcguire_offset(face_size, exponent) if mapping == "mcguire" else 0.0
    max_lod = math.log2(base_size)
    return min(max(level_of(face_size, base_size) + offset + lod_bias, 0.0), max_lod)
