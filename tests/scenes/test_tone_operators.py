"""The engines' tone-mapping operators against hand-evaluated and analytic values.

Each expectation is computed here from the published formula, independently of
scenes/model/tone_operators.py (grey inputs, where the colour matrices reduce to their row sums, so
the hand value is a scalar formula).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenes.model import tone_operators as ops
from scenes.model.tonemap import srgb_decode, srgb_encode


def grey(v: float) -> np.ndarray:
    return np.array([v, v, v], dtype=np.float64)


def narkowicz_by_hand(x: float) -> float:
    # Narkowicz 2016: x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14), saturated
    return min(max((2.51 * x * x + 0.03 * x) / (2.43 * x * x + 0.59 * x + 0.14), 0.0), 1.0)


def hill_by_hand(x: float) -> float:
    # three.js: x / 0.6, then Hill's RRT+ODT rational fit. On a grey input ACESInputMat's rows sum to
    # 1 (0.59719 + 0.35458 + 0.04823) and ACESOutputMat's rows to 1 (1.60475 - 0.53108 - 0.07367),
    # so grey stays grey and the value is the scalar fit.
    v = x / 0.6
    return min(max((v * v + 0.0245786 * v - 0.000090537) / (0.983729 * v * v + 0.4329510 * v + 0.238081), 0.0), 1.0)


def agx_grey_by_hand(x: float) -> float:
    # AgX on grey: the Rec.2020, inset, outset and back matrices all have rows summing to 1 (to 1e-4),
    # so the value is sigmoid((log2 x + 12.47393) / 16.499999)^2.2 with the sixth-order polynomial
    # written here in Horner form (the module writes it as powers).
    t = (math.log2(x) - (-12.47393)) / (4.026069 - (-12.47393))
    t = min(max(t, 0.0), 1.0)
    coeffs = [15.5, -40.14, 31.96, -6.868, 0.4298, 0.1191, -0.00232]
    p = 0.0
    for c in coeffs:
        p = p * t + c
    return max(p, 0.0) ** 2.2


@pytest.mark.parametrize("x", [0.0, 0.25, 1.0, 3.0, 100.0])
def test_reinhard_is_x_over_one_plus_x(x):
    assert ops.apply("reinhard", grey(x)) == pytest.approx(grey(x / (1 + x)), abs=1e-15)


@pytest.mark.parametrize("x", [0.0, 0.5, 1.0, 2.0])
def test_narkowicz_at_hand_points(x):
    assert ops.apply("aces-narkowicz", grey(x)) == pytest.approx(grey(narkowicz_by_hand(x)), abs=1e-12)
    # published property: "1 on input maps to ~0.8" (2.54 / 3.16)
    assert ops.apply("aces-narkowicz", grey(1.0))[0] == pytest.approx(2.54 / 3.16, abs=1e-12)


@pytest.mark.parametrize("x", [0.05, 0.18, 0.6, 1.0, 4.0])
def test_aces_hill_grey_is_the_scalar_fit(x):
    assert ops.apply("aces-hill", grey(x)) == pytest.approx(grey(hill_by_hand(x)), abs=2e-5)


def test_aces_hill_black_and_white_ends():
    # at 0 the fit is -0.000090537 / 0.238081 < 0: clamped to black
    assert ops.apply("aces-hill", grey(0.0)) == pytest.approx(grey(0.0), abs=0)
    # as x -> inf the fit tends to 1 / 0.983729 > 1: clamped to white
    assert ops.apply("aces-hill", grey(1e6)) == pytest.approx(grey(1.0), abs=0)


@pytest.mark.parametrize("rgb", [(0.1, 0.2, 0.3), (0.5, 0.3, 0.7), (0.08, 0.08, 0.08), (0.2, 0.795, 0.4)])
def test_pbr_neutral_is_the_identity_minus_its_offset_below_start_compression(rgb):
    # Khronos PBR Neutral: min channel >= 0.08 -> offset 0.04; peak - 0.04 < 0.8 - 0.04 -> no compression
    x = np.array(rgb)
    assert ops.apply("khronos-pbr-neutral", x) == pytest.approx(x - 0.04, abs=1e-15)


def test_pbr_neutral_toe_and_sun():
    # the toe: min channel x < 0.08 subtracts x - 6.25 x^2
    x = np.array([0.02, 0.3, 0.5])
    off = 0.02 - 6.25 * 0.02**2
    assert ops.apply("khronos-pbr-neutral", x) == pytest.approx(x - off, abs=1e-15)
    # a sun of 1e6 is compressed below 1: newPeak = 1 - 0.24^2 / (1e6 - 0.04 - 0.52)
    out = ops.apply("khronos-pbr-neutral", grey(1e6))
    expected = 1.0 - 0.24**2 / (1e6 - 0.04 + 0.24 - 0.76)
    assert np.all(out < 1.0)
    assert out == pytest.approx(grey(expected), abs=1e-12)


@pytest.mark.parametrize("x", [0.01, 0.18, 1.0, 8.0])
def test_agx_grey_against_hand_evaluation(x):
    assert ops.apply("agx", grey(x)) == pytest.approx(grey(agx_grey_by_hand(x)), abs=3e-4)


@pytest.mark.parametrize("name", ops.NAMES)
def test_monotone_in_luminance_and_finite(name):
    ramp = np.geomspace(1e-6, 1e6, 400)
    out = ops.apply(name, ramp[:, None] * np.array([1.0, 0.8, 0.6]))
    lum = out @ np.array([0.2126, 0.7152, 0.0722])
    assert np.all(np.diff(lum) >= -1e-12)
    extremes = ops.apply(name, np.array([[0.0, 0.0, 0.0], [1e6, 1e6, 1e6], [np.inf, 0.0, 1.0], [-1.0, 2.0, 0.0]]))
    assert np.all(np.isfinite(extremes)) and extremes.min() >= 0.0 and extremes.max() <= 1.0


@pytest.mark.parametrize("name", ops.NAMES)
def test_nan_and_bad_arguments_refused(name):
    with pytest.raises(ValueError, match="NaN"):
        ops.apply(name, np.array([0.5, np.nan, 0.1]))
    with pytest.raises(ValueError, match="exposure"):
        ops.apply(name, grey(0.5), exposure=0.0)
    with pytest.raises(ValueError, match=r"\(\.\.\., 3\)"):
        ops.apply(name, np.zeros((4, 4)))


def test_unknown_name_refused():
    with pytest.raises(ValueError, match="filmic"):
        ops.apply("filmic", grey(0.5))


@pytest.mark.parametrize("name", ["reinhard", "aces-narkowicz", "agx"])
def test_exposure_multiplies_first(name):
    assert ops.apply(name, grey(0.3), exposure=2.5) == pytest.approx(ops.apply(name, grey(0.75)), abs=1e-15)


def test_srgb_decode_inverts_encode():
    x = np.concatenate([np.linspace(0.0, 1.0, 10001), [0.0031308, 0.0031309, 1e-7]])
    assert srgb_decode(srgb_encode(x)) == pytest.approx(x, abs=2e-9)
    # hand points of IEC 61966-2-1: 0.5 encodes to 0.735357, 0.04045 decodes to 0.04045 / 12.92
    assert srgb_decode(np.array([0.7353569830524495])) == pytest.approx([0.5], abs=1e-12)
    assert srgb_decode(np.array([0.04045])) == pytest.approx([0.04045 / 12.92], abs=1e-15)


@pytest.mark.parametrize("attr,value,name,x,hand", [
    ("_NARKOWICZ", (2.51, 0.03, 2.43, 0.59, 0.15), "aces-narkowicz", 0.5, narkowicz_by_hand),
    ("ACES_HILL_PRESCALE", 1.0, "aces-hill", 0.6, hill_by_hand),
    ("AGX_MAX_EV", 4.5, "agx", 0.18, agx_grey_by_hand),
])
def test_negative_control_wrong_constant_is_caught(monkeypatch, attr, value, name, x, hand):
    monkeypatch.setattr(ops, attr, value)
    assert ops.apply(name, grey(x))[0] != pytest.approx(hand(x), abs=2e-3)


def test_negative_control_wrong_pbr_start_is_caught(monkeypatch):
    monkeypatch.setattr(ops, "PBR_NEUTRAL_START", 0.5)
    x = np.array([0.5, 0.3, 0.7])
    assert ops.apply("khronos-pbr-neutral", x) != pytest.approx(x - 0.04, abs=1e-6)
