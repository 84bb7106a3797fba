"""Level selection and the glossy LOD (realtime.engine.levels) against values worked out by hand.

The formulas (docs/contract.md section 3, steps 2 and 5): level(s) = log2(base / s); "auto" takes s linear in
the object's distance between 64 at 2 and 8 at 16, snapped to a power of two in log2;
lod = clamp(level(s) + offset(N) + b, 0, log2(base)) with offset 0 ("paper") or
McGuire's max(0, log2(s sqrt 3) - 0.5 log2(N + 1)).

Constants used below (to 12 digits): log2(sqrt 3) = 0.5 log2 3 = 0.792481250360;
log2(101) = 6.658211482751, log2(11) = 3.459431618637, log2(1e6 + 1) = 19.931570012018.
Tolerance: 1e-9 (the values are exact up to the 12 digits written).
"""

from __future__ import annotations

import pytest

from realtime.engine import levels

LOG2_SQRT3 = 0.792481250360


@pytest.mark.parametrize(("face_size", "base", "level"), [(256, 256, 0), (64, 256, 2), (8, 256, 5), (1, 256, 8),
                                                          (16, 64, 2), (1024, 1024, 0)])
def test_level_of_a_face_size(face_size, base, level):
    # 256 / 64 = 4 = 2^2; 256 / 8 = 32 = 2^5; 64 / 16 = 4 = 2^2
    assert levels.level_of(face_size, base) == level


@pytest.mark.parametrize(("distance", "base", "size"), [
    (2.0, 256, 64),    # t = 0: s = 64
    (0.5, 256, 64),    # nearer than AUTO_NEAR clamps to t = 0
    (4.0, 256, 64),    # t = 1/7: s = 64 - 56/7 = 56; log2 56 = 5.807 -> 2^6 = 64
    (6.0, 256, 64),    # t = 2/7: s = 48; log2 48 = 5.585 -> 2^6 = 64
    (8.0, 256, 32),    # t = 3/7: s = 40; log2 40 = 5.322 -> 2^5 = 32
    (9.0, 256, 32),    # t = 1/2: s = 36; log2 36 = 5.170 -> 32
    (12.0, 256, 32),   # t = 5/7: s = 24; log2 24 = 4.585 -> 2^5 = 32
    (14.0, 256, 16),   # t = 6/7: s = 16
    (15.0, 256, 16),   # t = 13/14: s = 12; log2 12 = 3.585 -> 2^4 = 16
    (16.0, 256, 8),    # t = 1: s = 8
    (40.0, 256, 8),    # beyond AUTO_FAR clamps to t = 1
    (2.0, 32, 32),     # s = 64 but never above the base
])
def test_auto_face_size_by_hand(distance, base, size):
    assert levels.auto_face_size(distance, base) == size


@pytest.mark.parametrize(("setting", "distance", "size"), [(16, 2.0, 16), ("auto", 9.0, 32), ("auto", 16.0, 8)])
def test_select_face_size(setting, distance, size):
    # a fixed size ignores the distance; "auto" at 9 is 32 and at 16 is 8 (worked out above)
    assert levels.select_face_size(setting, distance, 256) == size


@pytest.mark.parametrize(("face_size", "exponent", "offset"), [
    # log2(64 sqrt 3) - 0.5 log2(101) = 6.792481250360 - 3.329105741376 = 3.463375508985
    (64, 100.0, 3.463375508985),
    # log2(8 sqrt 3) - 0.5 log2(11) = 3.792481250360 - 1.729715809319 = 2.062765441041
    (8, 10.0, 2.062765441041),
    # N = 0 covers 2 pi sr: log2(16 sqrt 3) - 0 = 4.792481250360
    (16, 0.0, 4.792481250360),
    # N = 1e6: 6.792481250360 - 9.965785006009 < 0 -> 0
    (64, 1e6, 0.0),
])
def test_mcguire_offset_by_hand(face_size, exponent, offset):
    assert levels.mcguire_offset(face_size, exponent) == pytest.approx(offset, abs=1e-9)


@pytest.mark.parametrize(("face_size", "base", "bias", "mapping", "exponent", "lod"), [
    (64, 256, 0.0, "paper", 100.0, 2.0),            # level(64) = 2, no offset
    (64, 256, 1.5, "paper", 100.0, 3.5),            # 2 + 1.5
    (64, 256, -0.75, "paper", 100.0, 1.25),         # 2 - 0.75
    (64, 256, -3.0, "paper", 100.0, 0.0),           # 2 - 3 = -1, clamped to the finest level
    (16, 256, 10.0, "paper", 100.0, 8.0),           # 4 + 10 = 14, clamped to log2(256) = 8
    (64, 256, 0.0, "mcguire", 100.0, 5.463375508985),   # 2 + 3.463375508985
    (64, 256, -2.5, "mcguire", 100.0, 2.963375508985),  # 2 + 3.463375508985 - 2.5
    (64, 256, 2.0, "mcguire", 100.0, 7.463375508985),   # 2 + 3.463375508985 + 2
    (64, 256, 3.0, "mcguire", 100.0, 8.0),              # 8.463375508985 clamped to 8
    (8, 64, 0.5, "mcguire", 10.0, 5.562765441041),      # level(8 of 64) = 3, + 2.062765441041 + 0.5
    (64, 256, 1.0, "mcguire", 1e6, 3.0),                # the offset is 0 for a mirror-like lobe: 2 + 0 + 1
    (64, 64, -32.0, "mcguire", 0.0, 0.0),               # 0 + 6.79 - 32 < 0: clamped
])
def test_glossy_lod_by_hand(face_size, base, bias, mapping, exponent, lod):
    assert levels.glossy_lod(face_size, base, bias, mapping, exponent) == pytest.approx(lod, abs=1e-9)


@pytest.mark.parametrize(("face_size", "base", "bias", "mapping", "exponent", "lod"), [
    (64, 256, 3.0, "mcguire", 100.0, 8.463375508985),   # 2 + 3.463375508985 + 3, not clamped to 8
    (64, 256, -3.0, "paper", 100.0, -1.0),              # 2 - 3, not clamped to 0
    (8, 64, 0.5, "mcguire", 10.0, 5.562765441041),      # 3 + 2.062765441041 + 0.5
])
def test_glossy_lod_unclamped_by_hand(face_size, base, bias, mapping, exponent, lod):
    """The same sum before the cube's clamp (a 2D parameterization clamps to its own chain)."""
    if not hasattr(levels, "glossy_lod_unclamped"):
        pytest.skip("no glossy_lod_unclamped in this version of realtime.engine.levels")
    assert levels.glossy_lod_unclamped(face_size, base, bias, mapping, exponent) == pytest.approx(lod, abs=1e-9)
