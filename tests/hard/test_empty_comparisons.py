"""An empty comparison never passes a gate, and a threshold above the reference's noise floor fails
with the spp that would resolve it.

A comparison carries no signal when the reference has no lit pixel (both images black: PSNR 100, SSIM 1),
when every pixel of the reference is clipped white by the tone mapping (any test image as bright scores
PSNR 100), or when fewer pixels are covered than `metrics.MIN_PIXELS`. Its metrics are then null, a `warning:`
line says why, and the gate fails the scene with that reason unless the scene's [gate] table says
`allow_empty = true`. Negative controls: a lit comparison keeps its numbers, a threshold below the floor
is an ordinary check.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import scenes
from experiments.measure import comparison, metrics, pair
from experiments.runs import gate
from scenes.model.render import Render
from tests.hard.common import small_scene

SCENE = scenes.load("builtin:sphere-diffuse").with_overrides({"camera.width": 16, "camera.height": 16})


def render(value: float, covered: int | None = None, meta: dict | None = None) -> Render:
    """A 16 x 16 render of constant radiance `value`, its first `covered` pixels covered (all: None)."""
    mask = np.ones((16, 16), bool) if covered is None else (np.arange(256) < covered).reshape(16, 16)
    return Render(np.full((16, 16, 3), value, np.float32), mask, {}, dict(meta or {}))


# --------------------------------------------------------------------------- what counts as no signal


@pytest.mark.parametrize(("ref", "covered", "words"), [
    (0.0, None, "no lit pixel"),                      # both black: the one-sided sphere around the camera
    (1e-12, None, "no lit pixel"),                    # below half an 8-bit step once displayed
    (1.0, 0, "no pixel is covered"),                  # the object outside the view
    (1.0, 3, "fewer than the 4"),                     # a silhouette's edge, not an image
    (1e6, None, "no pixel of the reference below white"),  # clipped whole by the tone mapping's white point
])
def test_no_signal_reasons(ref, covered, words):
    b = metrics.display(SCENE, render(ref).rgb)
    mask = render(ref, covered).mask
    assert words in metrics.no_signal(b, mask)


def test_lit_or_large_enough_comparisons_have_signal():
    """Negative control: one lit pixel among black ones is signal; exactly MIN_PIXELS pixels are enough."""
    rgb = np.zeros((16, 16, 3), np.float32)
    rgb[5, 5] = 1.0
    assert metrics.no_signal(metrics.display(SCENE, rgb), np.ones((16, 16), bool)) is None
    lit = np.ones((4, 4, 3), np.float32) * 0.5
    assert metrics.no_signal(lit, np.eye(4, dtype=bool)) is None  # 4 pixels
    # the threshold: display value 0.5/255 is lit, just below is not
    assert metrics.no_signal(np.full((2, 2, 3), 0.5 / 255, np.float32), np.ones((2, 2), bool), 1) is None
    assert metrics.no_signal(np.full((2, 2, 3), 0.49 / 255, np.float32), np.ones((2, 2), bool), 1)


def test_one_pixel_below_white_is_signal():
    """Negative control of the white case: one channel of one pixel half an 8-bit step below 1 is signal (a test
    pixel darker than it shows), and a display value of exactly `WHITE` is white."""
    white = np.full((2, 2, 3), metrics.WHITE, np.float32)
    mask = np.ones((2, 2), bool)
    assert "below white" in metrics.no_signal(white, mask, 1)
    white[1, 0, 2] = 1.0 - 0.51 / 255
    assert metrics.no_signal(white, mask, 1) is None


@pytest.mark.parametrize("white_pixels", [0, 1, 3, 4])
def test_the_white_share_counts_pixels_white_in_every_channel(white_pixels):
    """k of 4 pixels white in all three channels: k / 4; a pixel white in two channels only is not white."""
    b = np.full((4, 1, 3), 0.5, np.float32)
    b[:white_pixels] = 1.0
    if white_pixels < 4:
        b[white_pixels, 0, :2] = 1.0  # two channels clipped, the third resolved
    assert metrics.white_share(b, np.ones((4, 1), bool)) == white_pixels / 4
    assert metrics.white_share(b, np.zeros((4, 1), bool)) is None


def _measure(test: Render, ref: Render, ref2: Render | None = None) -> tuple[pair.Measurement, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = pair.measure_pair(test, ref, SCENE, second_reference=ref2)
    return m, [str(w.message) for w in caught if issubclass(w.category, pair.EmptyComparison)]


def test_black_against_black_measures_nothing_and_warns():
    m, caught = _measure(render(0.0), render(0.0), render(0.0))
    assert (m.psnr, m.ssim, m.flip, m.rel_mse, m.noise_floor_psnr, m.psnr_unbiased.value) == (None,) * 6
    assert m.empty and "no lit pixel" in m.empty and len(caught) == 1 and "carry no signal" in caught[0]
    assert m.pixels == int(metrics.common_mask(np.ones((16, 16), bool), np.ones((16, 16), bool)).sum())
    result = comparison.compare(render(0.0), render(0.0), SCENE, measured=m)
    assert result["psnr"] is None and "no lit pixel" in result["no_signal"]


def white_on(share: float) -> Render:
    """`render(0.5)` with its first `share` of pixels (row order) far above the tone mapping's white point."""
    r = render(0.5)
    r.rgb.reshape(-1, 3)[: int(round(share * 256))] = 1e6
    return r


@pytest.mark.parametrize(("share", "warns"), [(0.6, True), (0.4, False)])
def test_a_comparison_mostly_clipped_white_keeps_its_metrics_and_warns(share, warns):
    """More than half the compared pixels white in the reference: the metrics stand, a ClippedComparison
    warning names the share and `compare` reports it (`clipped_share`, which the gate fails). Control: 40 %
    white measures without either."""
    ref = white_on(share)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = pair.measure_pair(render(0.4), ref, SCENE, second_reference=ref)
    clipped = [str(w.message) for w in caught if issubclass(w.category, pair.ClippedComparison)]
    assert m.psnr is not None and m.empty is None
    share_counted = metrics.white_share(m.reference, m.mask)
    assert (share_counted > pair.CLIPPED_SHARE) is warns and m.clipped == share_counted
    assert len(clipped) == int(warns)
    result = comparison.compare(render(0.4), ref, SCENE, measured=m)
    if warns:
        assert f"{share_counted:.0%} of the compared pixels display as white" in clipped[0]
        assert result["clipped_share"] == share_counted
    else:
        assert "clipped_share" not in result


def test_the_gate_fails_a_mostly_clipped_comparison_whatever_its_metrics():
    """A comparison 99 % clipped white in the reference fails with that reason though its PSNR clears the bound
    (its clipped pixels' zero errors dilute the rest's). Control: the same metrics without the share pass."""
    failures = gate.evaluate({"psnr": 58.4, "noise_floor_psnr": 57.0, "clipped_share": 0.99}, {"min_psnr": 30.0})
    assert len(failures) == 1 and "99% of the compared pixels display as white" in failures[0]
    assert "lower tonemap.exposure" in failures[0]
    assert gate.evaluate({"psnr": 58.4, "noise_floor_psnr": 57.0}, {"min_psnr": 30.0}) == []


def test_a_lit_comparison_keeps_its_metrics():
    """Negative control: the same images lit give numbers and no warning, and no `no_signal` key."""
    m, caught = _measure(render(0.4), render(0.5), render(0.5))
    assert m.psnr is not None and m.ssim is not None and m.flip is not None and m.empty is None and caught == []
    assert "no_signal" not in comparison.compare(render(0.4), render(0.5), SCENE, measured=m)


# --------------------------------------------------------------------------- the gate's verdict


def test_the_gate_fails_an_empty_comparison_with_its_reason():
    failures = gate.evaluate({"psnr": None, "no_signal": "no lit pixel in the reference"}, {"min_psnr": 20.0})
    assert len(failures) == 1 and "empty comparison" in failures[0] and "no lit pixel" in failures[0]
    assert "allow_empty = true" in failures[0]
    # with no thresholds at all (a baseline gate), still a failure
    assert gate.evaluate({"no_signal": "3 covered pixels"}, {})


def test_allow_empty_lets_an_expected_empty_comparison_pass():
    assert gate.evaluate({"psnr": None, "no_signal": "no lit pixel"}, {"min_psnr": 20.0}, allow_empty=True) == []
    # negative control: allow_empty does not excuse a measured comparison that fails its threshold
    assert gate.evaluate({"psnr": 10.0, "noise_floor_psnr": 40.0}, {"min_psnr": 20.0}, allow_empty=True)


@pytest.mark.parametrize(("value", "ok"), [("true", True), ("false", True), ("yes", False), ("1", False),
                                           ("0.5", False), ('"true"', False)])
def test_allow_empty_is_validated_like_the_other_gate_keys(value, ok):
    base = scenes.load("builtin:sphere-diffuse")
    if ok:
        assert base.with_overrides({"gate.allow_empty": value}).gate.allow_empty is (value == "true")
    else:
        with pytest.raises(scenes.SceneError, match=r"gate\.allow_empty"):
            base.with_overrides({"gate.allow_empty": value})


def test_allow_empty_leaves_the_content_id_alone():
    from experiments.runs.rows import content_id

    base = scenes.load("builtin:sphere-diffuse")
    assert content_id(base.with_overrides({"gate.allow_empty": True})) == content_id(base)


# --------------------------------------------------------------------------- thresholds above the noise floor


def test_spp_for_floor_by_hand():
    """The floor rises 10 log10(2) = 3.0103 dB per doubling of spp (noise variance ~ 1 / spp)."""
    assert gate.spp_for_floor(29.9, 64, 30.0) == 128  # one doubling: 32.91 dB
    assert gate.spp_for_floor(29.9, 64, 32.91) == 128 and gate.spp_for_floor(29.9, 64, 32.92) == 256
    assert gate.spp_for_floor(29.9, 64, 36.0) == 512  # 29.9 + 2 x 3.01 = 35.92 < 36 <= 38.93
    assert gate.spp_for_floor(29.9, 64, 29.0) == 64  # already resolved
    assert gate.spp_for_floor(10.0, 1 << 20, 100.0) == 1 << 24  # the schema's largest spp
    # independent check of the rule: 10 log10(spp' / spp) is the rise
    spp = gate.spp_for_floor(21.3, 16, 33.3)
    assert 21.3 + 10 * math.log10(spp / 16) >= 33.3 > 21.3 + 10 * math.log10(spp / 32)


def test_a_threshold_no_allowed_spp_reaches_says_so():
    """33.1 dB at 64 spp rises 10 log10(2^24 / 64) = 54.2 dB at most, to 87.3 dB: 99 dB is out of reach."""
    why = gate.unresolvable(99.0, 33.1, 64)
    assert f"not even reference.spp = {1 << 24}, the most allowed, would (its floor about 87 dB)" in why
    assert "would resolve it" not in why
    assert "reference.spp = 128 would resolve it" in gate.unresolvable(35.0, 33.1, 64)  # the control


@pytest.mark.parametrize("psnr", [29.7, 29.95, None])
def test_a_threshold_above_the_floor_fails_naming_floor_and_spp(psnr):
    m = {"psnr": psnr, "noise_floor_psnr": 29.9, "reference_spp": 64}
    (failure,) = gate.evaluate(m, {"min_psnr": 30.0})
    assert "noise floor 29.90 dB" in failure and "64 spp" in failure and "reference.spp = 128" in failure


def test_thresholds_the_reference_can_resolve_are_ordinary_checks():
    """Negative controls: below the floor, and a noise-free reference (floor = the PSNR cap)."""
    assert gate.evaluate({"psnr": 35.0, "noise_floor_psnr": 40.0, "reference_spp": 64}, {"min_psnr": 30.0}) == []
    assert gate.evaluate({"psnr": 25.0, "noise_floor_psnr": 40.0, "reference_spp": 64},
                         {"min_psnr": 30.0}) == ["psnr = 25, required >= 30"]
    assert gate.evaluate({"psnr": 60.0, "noise_floor_psnr": metrics.PSNR_CAP}, {"min_psnr": 50.0}) == []


# --------------------------------------------------------------------------- end to end


@pytest.mark.gl
@pytest.mark.mitsuba
def test_camera_inside_a_sphere_fails_the_gate_unless_allowed(tmp_path, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))
    inside = {"camera.origin": [0.0, 0.0, 0.3], "objects.0.scale": 2.0}
    scene = small_scene("builtin:sphere-blend", **inside)
    with pytest.warns(pair.EmptyComparison, match="no lit pixel"):
        (r,) = gate.compare_all([(scene, {"min_psnr": 20.0})], noise=False)
    assert not r.passed and r.metrics["psnr"] is None and "empty comparison" in r.failures[0]
    allowed = small_scene("builtin:sphere-blend", **inside, **{"gate.allow_empty": True})
    with pytest.warns(pair.EmptyComparison):
        (r,) = gate.compare_all([(allowed, {"min_psnr": 20.0})], noise=False)
    assert r.passed and any("allow_empty" in w for w in r.warnings)
    # negative control: the camera outside, the same sphere: measured and passing
    (r,) = gate.compare_all([(small_scene("builtin:sphere-blend"), {"min_psnr": 5.0})], noise=False)
    assert r.passed and r.metrics["psnr"] is not None


def test_an_empty_comparison_against_a_measured_baseline_says_why():
    from tests.experiments.test_gate_baseline import record

    new = record()
    new["metrics"].update(psnr=None, ssim=None, flip=None, no_signal="no lit pixel in the reference")
    _, failures, _ = gate.compare_record(new, record(), {})
    assert failures and all("no lit pixel" in f for f in failures[:3])
    # negative control: both empty, nothing to compare, nothing fails
    _, failures, _ = gate.compare_record(new, new, {})
    assert failures == []
