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
