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

import pytest

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
