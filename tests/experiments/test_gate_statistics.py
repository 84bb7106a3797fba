"""experiments.runs.gate_statistics and the baseline comparison at its boundaries, by hand.

Expected values are hand computations (written out beside each case) or exact binary fractions, so that
a comparison whose boundary moved (> against >=), a worsening with its sign flipped, a pixel count taken
from one run only, or an explicit tolerance of 0 read as "none given" changes the outcome of a test.
Records go through a baseline file and `gate.read_baseline`, as the gate reads them.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from experiments.measure import metrics
from experiments.runs import gate, gate_statistics

TINY = 2.0**-30  # far above float rounding at these magnitudes, far below any tolerance in the cases


@pytest.mark.parametrize(("baseline", "new", "worse", "tolerance", "fails"), [
    # PSNR and SSIM: lower is worse (worse = -1)
    (30.0, 29.5, -1, 0.5, False),           # a fall of exactly the tolerance passes
    (30.0, 29.5 - TINY, -1, 0.5, True),     # just beyond it fails
    (30.0, 30.0, -1, 0.0, False),           # unchanged at a tolerance of 0 passes
    (30.0, 30.0 - TINY, -1, 0.0, True),     # any fall at a tolerance of 0 fails
    (30.0, 31.0, -1, 0.5, False),           # a rise larger than the tolerance is an improvement
    (0.75, 0.5, -1, 0.25, False),           # SSIM 0.75 -> 0.5 at tolerance 0.25: exactly at it
    (0.75, 0.5 - TINY, -1, 0.25, True),
    # FLIP: higher is worse (worse = +1)
    (0.25, 0.5, +1, 0.25, False),
    (0.25, 0.5 + TINY, +1, 0.25, True),
    (0.5, 0.0, +1, 0.25, False),            # a fall of FLIP larger than the tolerance is an improvement
])
def test_worsened_beyond_is_strict_and_one_sided(baseline, new, worse, tolerance, fails):
    """A worsening equal to its tolerance passes, one beyond it fails, an improvement never fails
    (the values are exact binary fractions, so the equal cases are exactly equal)."""
    assert gate_statistics.worsened_beyond(baseline, new, worse, tolerance) is fails


@pytest.mark.parametrize(("base_pixels", "new_pixels"), [(10000, 2500), (2500, 10000)])
def test_psnr_tolerance_takes_the_smaller_pixel_count(base_pixels, new_pixels):
    """Same reference, unequal covered pixels: N is the smaller count. By hand with M_base = 1e-3 (30 dB),
    M_new = 10^-2.9 (29 dB), sigma = 0.01 (floor 40 dB), N = 2500: s = 2 * 0.01 * (0.0316228 + 0.0354813)
    / 50 = 2.684165e-5, tolerance = 10 log10(1 + 2 s / 1e-3) = 0.227101 dB; with N = 10000 it would be
    0.115035 dB."""
    base = {"psnr": 30.0, "noise_floor_psnr": 40.0, "pixels": base_pixels}
    new = {"psnr": 29.0, "noise_floor_psnr": 40.0, "pixels": new_pixels}
    assert gate_statistics.psnr_tolerance_db(base, new, same_reference=True) == pytest.approx(0.227101, abs=2e-6)


def test_psnr_tolerance_at_its_boundary_with_different_references():
    """Different references, equal floors (no shift): mse_se 3e-5 and 4e-5 give s = 5e-5, z s = 1e-4, so
    the boundary is M_new = 1e-3 + 1e-4 = 1.1e-3: PSNR 29.586073 dB, a tolerance of 10 log10(1.1) =
    0.4139269 dB. A PSNR a micro-dB above the boundary passes, one below fails."""
    base = {"psnr": 30.0, "noise_floor_psnr": 40.0, "pixels": 10000, "mse_se": 3e-5}
    for new_psnr, fails in ((29.5860731 + 1e-6, False), (29.5860731 - 1e-6, True)):
        new = {"psnr": new_psnr, "noise_floor_psnr": 40.0, "pixels": 9000, "mse_se": 4e-5}
        tolerance = gate_statistics.psnr_tolerance_db(base, new, same_reference=False)
        assert tolerance == pytest.approx(0.4139269, abs=1e-7)
        assert gate_statistics.worsened_beyond(30.0, new_psnr, -1, tolerance) is fails


# --------------------------------------------------------------------------- records through a baseline file


def record(psnr: float = 30.0, ssim: float = 0.75, flip: float = 0.25, pixels: int = 10000, floor: float = 40.0,
           ref: str = "r0") -> dict:
    """A scene record as --write-baseline stores it (the fields the comparison reads)."""
    return {"name": "s", "spec": "builtin:sphere-phong", "sets": {}, "settings": {},
            "identity": {"iblcheck": "0.1.0", "gl": "llvmpipe", "techniques": {}, "reference_sha256": ref,
                         "reference": {"spp": 64, "seed": 0, "variant": "llvm_ad_rgb"}},
            "metrics": {"psnr": psnr, "ssim": ssim, "flip": flip, "noise_floor_psnr": floor, "pixels": pixels,
                        "mse_se": 2e-5, "ssim_se": 0.001, "flip_se": 0.0005},
            "timings": {"realtime_ms": {"total": 10.0}}}


def compare(tmp_path: Path, new: dict, base: dict, tolerances: dict) -> dict[str, gate.Delta]:
    """`new` against `base` written to and read back from a baseline file: the deltas by metric."""
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps({"format": gate.FORMAT, "version": gate.VERSION, "scenes": {"s": base}}))
    entry = gate.read_baseline(path)["scenes"]["s"]
    deltas, failures, _ = gate.compare_record(new, entry, tolerances)
    assert len(failures) == sum(d.failed for d in deltas)
    return {d.metric: d for d in deltas}


@pytest.mark.parametrize(("new_psnr", "tolerance_db", "fails"), [
    (30.0, 0.0, False),     # unchanged at --tolerance-db 0 passes
    (29.99, 0.0, True),     # a fall of 0.01 dB fails at 0 (the noise rule would allow 0.115 dB)
    (29.5, 0.5, False),     # a fall of exactly --tolerance-db passes
    (29.5 - TINY, 0.5, True),
])
def test_tolerance_db_boundary_through_a_baseline_file(tmp_path, new_psnr, tolerance_db, fails):
    """`--tolerance-db` replaces the rule, including 0 (not "no tolerance given"), and a fall equal to
    it passes: docs/gate.md."""
    d = compare(tmp_path, record(psnr=new_psnr), record(), {"tolerance_db": tolerance_db})["psnr"]
    assert d.tolerance == tolerance_db
    assert d.failed is fails


@pytest.mark.parametrize(("metric", "new", "fails"), [
    ("ssim", 0.5, False), ("ssim", 0.5 - TINY, True), ("flip", 0.5, False), ("flip", 0.5 + TINY, True),
])
def test_ssim_and_flip_tolerance_boundaries_through_a_baseline_file(tmp_path, metric, new, fails):
    """SSIM 0.75 and FLIP 0.25 in the baseline, a tolerance of 0.25: worsening to exactly 0.5 passes."""
    d = compare(tmp_path, record(**{metric: new}), record(), {f"tolerance_{metric}": 0.25})[metric]
    assert d.failed is fails


@pytest.mark.parametrize(("base_pixels", "new_pixels"), [(10000, 2500), (2500, 10000)])
def test_unequal_pixel_counts_through_a_baseline_file(tmp_path, base_pixels, new_pixels):
    """Same reference, 30 -> 29.8 dB, sigma 0.01: with N = 2500 (the smaller count) the tolerance is
    10 log10(1 + 2 s / 1e-3), s = 2 * 0.01 * (sqrt(1e-3) + sqrt(10^-2.98)) / 50 = 2.559286e-5: 0.216794 dB,
    so the 0.2 dB fall passes; with N = 10000 it would be 0.109750 dB and the fall would fail."""
    d = compare(tmp_path, record(psnr=29.8, pixels=new_pixels), record(pixels=base_pixels), {})["psnr"]
    assert d.tolerance == pytest.approx(0.216794, abs=2e-6)
    assert not d.failed


def test_a_noise_free_reference_passes_an_unchanged_image_and_fails_any_fall(tmp_path):
    """A noise-free reference (floor at the cap, 100 dB: sigma = 1e-5) leaves, with M = 1e-3 and N = 10000,
    s = 2 * 1e-5 * 2 sqrt(1e-3) / 100 and a tolerance of 10 log10(1 + 2 s / 1e-3) = 1.1e-4 dB: the
    unchanged image passes, a fall of 0.001 dB fails."""
    base = record(floor=100.0)
    d = compare(tmp_path, record(floor=100.0), base, {})["psnr"]
    s = 2 * 1e-5 * 2 * math.sqrt(1e-3) / 100
    assert d.tolerance == pytest.approx(10 * math.log10(1 + 2 * s / 1e-3), rel=1e-9)
    assert not d.failed
    assert compare(tmp_path, record(psnr=29.999, floor=100.0), base, {})["psnr"].failed


# --------------------------------------------------------------------------- unknown inputs and the defaults


@pytest.mark.parametrize(("base_se", "new_se"), [(None, 4e-5), (4e-5, None)])
def test_an_unknown_standard_error_counts_as_zero(base_se, new_se):
    """A run without a standard error (None: too few pixels to estimate it) adds nothing to the combined
    one. By hand, different references with equal floors and M_base = 1e-3: s = 4e-5, z s = 8e-5, a PSNR
    tolerance of 10 log10(1.08) = 0.3342376 dB; SSIM/FLIP with the other run's se 0.003: 2 * 0.003 =
    0.006. Negative control: counting the missing one as 1 would give tolerances of about 33 dB and 2."""
    base = {"psnr": 30.0, "noise_floor_psnr": 40.0, "pixels": 10000, "mse_se": base_se}
    new = {"psnr": 29.0, "noise_floor_psnr": 40.0, "pixels": 10000, "mse_se": new_se}
    assert gate_statistics.psnr_tolerance_db(base, new, same_reference=False) == pytest.approx(0.3342376, abs=1e-7)
    assert 10 * math.log10(1 + 2 * math.sqrt(1 + 4e-5**2) / 1e-3) > 30.0
    metric_se = (None, 0.003) if base_se is None else (0.003, None)
    assert gate_statistics.metric_tolerance(*metric_se) == pytest.approx(0.006, abs=1e-15)


def test_metric_tolerance_has_no_shift_unless_given():
    """Without a shift the SSIM/FLIP tolerance is z sqrt(se_base^2 + se_new^2) alone: 2 * sqrt(0.003^2 +
    0.004^2) = 0.01 (a 3-4-5 triangle); a shift of 0.002 adds to it: 0.012."""
    assert gate_statistics.metric_tolerance(0.003, 0.004) == pytest.approx(0.01, abs=1e-15)
    assert gate_statistics.metric_tolerance(0.003, 0.004, shift=0.002) == pytest.approx(0.012, abs=1e-15)


def test_psnr_tolerance_is_negative_with_a_cleaner_reference():
    """A new reference cleaner than the baseline's (floor 30 -> 40 dB: s2 1e-3 -> 1e-4) is expected to raise
    the PSNR, so the tolerance is negative. By hand with M_base = 1e-2 (20 dB), mse_se 3e-5 and 4e-5
    (s = 5e-5, z s = 1e-4): 1 + (1e-4 - 9e-4) / 1e-2 = 0.92, 10 log10 0.92 = -0.3621217 dB. A PSNR rise of
    0.3 dB, short of what the cleaner reference alone explains, fails; one of 0.4 dB passes."""
    base = {"psnr": 20.0, "noise_floor_psnr": 30.0, "pixels": 10000, "mse_se": 3e-5}
    new = {"psnr": 20.3, "noise_floor_psnr": 40.0, "pixels": 10000, "mse_se": 4e-5}
    tolerance = gate_statistics.psnr_tolerance_db(base, new, same_reference=False)
    assert tolerance == pytest.approx(-0.3621217, abs=1e-7)
    assert gate_statistics.worsened_beyond(20.0, 20.3, -1, tolerance)
    assert not gate_statistics.worsened_beyond(20.0, 20.4, -1, tolerance)


def test_psnr_tolerance_of_a_single_covered_pixel():
    """Same reference, N = 1 covered pixel in both runs (the standard error divides by sqrt(1)): by hand with
    M_base = M_new = 1e-2 (20 dB) and sigma = 0.01 (floor 40 dB): s = 2 * 0.01 * (0.1 + 0.1) / 1 = 4e-3,
    tolerance 10 log10(1 + 8e-3 / 1e-2) = 10 log10 1.8 = 2.5527251 dB (N = 2 would give 1.9470 dB)."""
    run = {"psnr": 20.0, "noise_floor_psnr": 40.0, "pixels": 1}
    assert gate_statistics.psnr_tolerance_db(run, dict(run), same_reference=True) == pytest.approx(2.5527251, abs=1e-7)
    assert 10 * math.log10(1 + 8e-3 / math.sqrt(2) / 1e-2) < 2.0


@pytest.mark.parametrize(("metric", "base", "new", "want"), [
    # FLIP rises with noise (slopes 10 and 30, mean 20): s2 1e-4 -> 10^-3.4 = 3.981072e-4 explains a rise of
    # 20 * 2.981072e-4 = 0.005962143
    ("flip", {"flip_noise_slope": 10.0, "noise_floor_psnr": 40.0},
     {"flip_noise_slope": 30.0, "noise_floor_psnr": 34.0}, 0.005962143),
    # only one run measured a slope: that slope alone
    ("flip", {"noise_floor_psnr": 40.0}, {"flip_noise_slope": 20.0, "noise_floor_psnr": 34.0}, 0.005962143),
    # SSIM falls with noise (negative slope): the same fall, a worsening of the same size
    ("ssim", {"ssim_noise_slope": -20.0, "noise_floor_psnr": 40.0},
     {"ssim_noise_slope": -20.0, "noise_floor_psnr": 34.0}, 0.005962143),
    # a cleaner new reference: FLIP expected to fall, no widening (never narrowed either)
    ("flip", {"flip_noise_slope": 20.0, "noise_floor_psnr": 34.0},
     {"flip_noise_slope": 20.0, "noise_floor_psnr": 40.0}, 0.0),
    # no slope measured, or either floor unknown: 0
    ("flip", {"noise_floor_psnr": 40.0}, {"noise_floor_psnr": 34.0}, 0.0),
    ("flip", {"flip_noise_slope": 20.0, "noise_floor_psnr": None},
     {"flip_noise_slope": 20.0, "noise_floor_psnr": 34.0}, 0.0),
    ("ssim", {"ssim_noise_slope": -20.0, "noise_floor_psnr": 40.0}, {"ssim_noise_slope": -20.0}, 0.0),
])
def test_noise_shift_by_hand(metric, base, new, want):
    """The worsening a noisier new reference explains: mean slope times the change of noise variance, in the
    metric's worse direction (FLIP up, SSIM down), never negative, and 0 without a slope or with either
    floor unknown. Expected values by hand (beside each case)."""
    assert gate_statistics.noise_shift(metric, base, new) == pytest.approx(want, abs=1e-9)


# --------------------------------------------------------------------------- block_se and metric_noise by hand

NOISE_KEYS = {"mse_se", "ssim_se", "flip_se", "ssim_noise_slope", "flip_noise_slope"}


def test_block_se_of_two_tiles_by_hand():
    """Two sampling units are enough for a spread. Tiles of 2 x 2 (a 2 x 4 map) with sums S = (4, 0),
    counts 4 and 4: D = 0.5, S - c D = (2, -2), se = sqrt(2 / 1 * 8) / 8 = 0.5."""
    diff = np.array([[1.0, 1.0, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0]])
    assert gate_statistics.block_se(diff, np.ones((2, 4), bool), block=2) == pytest.approx(0.5, abs=1e-15)
    first_tile = np.zeros((2, 4), bool)
    first_tile[:, :2] = True
    assert gate_statistics.block_se(diff, first_tile, block=2) is None  # one unit: no spread


def _noise_images(size: tuple[int, int], seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A smooth truth in [0.2, 0.8], a test image off it, and references truth + n, truth - n with n = +-0.05
    (random signs): their mean is the truth, and half their mean squared difference (the noise variance the
    gate estimates from two seeds) is (2 * 0.05)^2 / 2 = 0.005 exactly."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size[0], 0:size[1]] / max(size)
    truth = np.stack([0.3 + 0.4 * x, 0.5 + 0.2 * np.sin(6 * y), 0.4 + 0.3 * x * y], axis=-1)
    test = truth + 0.04 * np.sin(9 * x)[..., None]
    n = 0.05 * rng.choice([-1.0, 1.0], truth.shape)
    return test, truth + n, truth - n, truth


def test_mse_se_by_hand_on_a_two_by_two_image():
    """mse_se from per-pixel differences D = mean_c (t - r1)^2 - (t - r2)^2 with single pixels as units.
    t = 0, r1 = 1 at pixel (0, 0) only, r2 = 1 at (0, 1) only: D = (1, -1, 0, 0), mean 0, sum of squares 2,
    se = sqrt(4 / 3 * 2) / 4, mse_se = se / sqrt(2) = 1 / (2 sqrt(3)). A sum instead of the difference gives
    D = (1, 1, 0, 0) and 1 / (2 sqrt(6)); 2 x 2 tiles give a single unit (None)."""
    t = np.zeros((2, 2, 3))
    r1, r2 = t.copy(), t.copy()
    r1[0, 0], r2[0, 1] = 1.0, 1.0
    out = gate_statistics.metric_noise(t, r1, r2, np.ones((2, 2), bool))
    want, wrong = 1 / (2 * math.sqrt(3)), 1 / (2 * math.sqrt(6))
    assert out["mse_se"] == pytest.approx(want, abs=1e-12)
    assert abs(want - wrong) > 0.05  # the check tells the two apart


@pytest.mark.parametrize("mask_kind", ["empty", "one pixel", "border pixel"])
def test_metric_noise_without_enough_pixels_gives_none(mask_kind: str):
    """Every estimate is present and None where it cannot be estimated, never an error or NaN: an empty
    mask; a single covered pixel (one sampling unit for every standard error); a single pixel on the
    border of a 16 x 16 image, which SSIM's window leaves out."""
    test, r1, r2, _ = _noise_images((16, 16))
    mask = np.zeros((16, 16), bool)
    if mask_kind == "one pixel":
        mask[8, 8] = True
    elif mask_kind == "border pixel":
        mask[0, 5] = True
    out = gate_statistics.metric_noise(test, r1, r2, mask)
    assert set(out) == NOISE_KEYS
    assert out["mse_se"] is None and out["ssim_se"] is None and out["flip_se"] is None
    if mask_kind != "one pixel":
        assert out["ssim_noise_slope"] is None
    if mask_kind == "empty":
        assert all(v is None for v in out.values())


def test_metric_noise_on_an_image_smaller_than_the_ssim_window():
    """A 6 x 6 image (SSIM's window is 7): no SSIM estimates (None, keys present), the MSE ones still."""
    test, r1, r2, _ = _noise_images((6, 6))
    out = gate_statistics.metric_noise(test, r1, r2, np.ones((6, 6), bool))
    assert set(out) == NOISE_KEYS
    assert out["ssim_se"] is None and out["ssim_noise_slope"] is None
    assert out["mse_se"] is not None and out["flip_noise_slope"] is not None


def test_metric_noise_with_one_tile_of_ssim_and_flip():
    """A 16 x 16 image is one 16 x 16 sampling unit: ssim_se and flip_se are None (no error), mse_se (single
    pixels as units) is a number."""
    test, r1, r2, _ = _noise_images((16, 16))
    out = gate_statistics.metric_noise(test, r1, r2, np.ones((16, 16), bool))
    assert out["ssim_se"] is None and out["flip_se"] is None and out["mse_se"] > 0


@pytest.mark.parametrize("size", [(7, 7), (24, 40)])
def test_noise_slopes_against_the_mean_reference(size: tuple[int, int]):
    """The slopes: (metric against r1 - metric against (r1 + r2) / 2) / (variance / 2), with the variance
    per value half the mean squared difference of the seeds. With r1,2 = truth +- n, |n| = 0.05, the mean
    reference is the truth and the variance (2 * 0.05)^2 / 2 = 0.005 (hand value), so the slopes are
    (metric(t, r1) - metric(t, truth)) / 0.0025, from metrics.ssim and metrics.flip. At 7 x 7 SSIM's window
    just fits."""
    test, r1, r2, truth = _noise_images(size)
    mask = np.ones(size, bool)
    out = gate_statistics.metric_noise(test, r1, r2, mask)
    ssim_slope = (metrics.ssim(test, r1, mask) - metrics.ssim(test, truth, mask)) / 0.0025
    flip_slope = (metrics.flip(test, r1, mask) - metrics.flip(test, truth, mask)) / 0.0025
    assert out["ssim_noise_slope"] == pytest.approx(ssim_slope, rel=1e-6)
    assert out["flip_noise_slope"] == pytest.approx(flip_slope, rel=1e-6)
    assert abs(ssim_slope) > 1.0 and abs(flip_slope) > 1.0  # large enough that a factor 2 or 3 shows


def test_noise_slopes_are_none_for_a_noise_free_reference():
    """Two identical seeds: no noise variance, no slope (None, not a division by zero); the standard
    errors are 0 (the maps against both seeds agree)."""
    test, r1, _, _ = _noise_images((32, 32))
    out = gate_statistics.metric_noise(test, r1, r1.copy(), np.ones((32, 32), bool))
    assert out["ssim_noise_slope"] is None and out["flip_noise_slope"] is None
    assert out["mse_se"] == 0.0 and out["ssim_se"] == 0.0 and out["flip_se"] == 0.0


def test_ssim_and_flip_standard_errors_from_their_maps():
    """ssim_se and flip_se are block_se of the map difference against the two seeds over sqrt(2)
    (16 x 16 units; SSIM over its selection), on a 32 x 48 image (6 units)."""
    test, r1, r2, _ = _noise_images((32, 48))
    mask = np.ones((32, 48), bool)
    out = gate_statistics.metric_noise(test, r1, r2, mask)
    one, two = metrics.ssim(test, r1, mask, full=True), metrics.ssim(test, r2, mask, full=True)
    want_ssim = gate_statistics.block_se(one.map - two.map, one.selection, 16) / math.sqrt(2)
    want_flip = gate_statistics.block_se(metrics.flip_map(test, r1) - metrics.flip_map(test, r2), mask, 16)
    assert out["ssim_se"] == pytest.approx(want_ssim, rel=1e-9)
    assert out["flip_se"] == pytest.approx(want_flip / math.sqrt(2), rel=1e-9)


def test_given_maps_are_used():
    """`ssim_map` and `flip_map` given are the maps against the first seed: a map raised by 0.01 everywhere
    raises each slope by 0.01 / (variance / 2) = 0.01 / 0.0025 = 4 (the variance 0.005 by hand)."""
    test, r1, r2, _ = _noise_images((24, 40))
    mask = np.ones((24, 40), bool)
    plain = gate_statistics.metric_noise(test, r1, r2, mask)
    ssim_map = metrics.ssim(test, r1, mask, full=True).map + 0.01
    given = gate_statistics.metric_noise(test, r1, r2, mask, ssim_map=ssim_map,
                                         flip_map=metrics.flip_map(test, r1) + 0.01)
    assert given["ssim_noise_slope"] - plain["ssim_noise_slope"] == pytest.approx(4.0, rel=1e-6)
    assert given["flip_noise_slope"] - plain["flip_noise_slope"] == pytest.approx(4.0, rel=1e-6)


def test_metric_noise_computes_in_double_precision():
    """Single-precision images (as the renderer and the path tracer give them) give the estimates of the
    same values in double precision: the squared differences and their means are not rounded to float32."""
    test, r1, r2, _ = _noise_images((24, 40))
    mask = np.ones((24, 40), bool)
    f32 = [np.asarray(x, np.float32) for x in (test, r1, r2)]
    single = gate_statistics.metric_noise(*f32, mask)
    double = gate_statistics.metric_noise(*(np.asarray(x, np.float64) for x in f32), mask)
    for key in NOISE_KEYS:
        assert single[key] == pytest.approx(double[key], rel=1e-12, abs=0), key
