"""The one measuring path (experiments/measure/pair.py) against the metrics recomputed independently.

Every number `measure_pair`, `compare`, the gate's noise estimates and a sweep row report must be
exactly (bit for bit) what the metric functions, or the libraries behind them, give when called
directly on the same pair; and each expensive step (tone mapping, SSIM, FLIP) runs once per pair.
"""

from __future__ import annotations

import json
import math

import flip_evaluator
import numpy as np
import pytest
from scipy.ndimage import binary_erosion
from skimage.metrics import structural_similarity

import scenes
from experiments.measure import comparison, metrics, pair
from experiments.publish import images
from experiments.runs import gate
from scenes.model.render import Render
from scenes.model.tonemap import adaptation_luminance, to_uint8, tonemap

H, W = 40, 48


@pytest.fixture(scope="module")
def scene():
    return scenes.load("builtin:sphere-phong")


def _render(rgb: np.ndarray, mask: np.ndarray, renderer: str = "realtime") -> Render:
    return Render(rgb=rgb.astype(np.float32), mask=mask, timings={"filter": 1.0, "draw": 2.0, "total": 3.0,
                                                                  "total_p90": 4.0, "render": 5000.0},
                  meta={"renderer": renderer, "spp": 16, "unsimulated_effects": ["x"], "face_size": 8,
                        "sh_coeffs": [[0.5, 0.25, 0.125]]})


@pytest.fixture(scope="module")
def renders():
    """A test image, a reference and its second seed (independent noise), with different coverage."""
    rng = np.random.default_rng(7)
    truth = rng.uniform(0.05, 2.0, size=(H, W, 3))
    yy, xx = np.mgrid[:H, :W]
    disc = (yy - H / 2) ** 2 + (xx - W / 2) ** 2 < (0.45 * H) ** 2
    shifted = (yy - H / 2) ** 2 + (xx - W / 2 - 2) ** 2 < (0.45 * H) ** 2
    test = _render(truth * 1.05 + 0.02, disc)
    ref = _render(truth + rng.normal(0, 0.05, truth.shape), shifted, "reference")
    ref2 = _render(truth + rng.normal(0, 0.05, truth.shape), shifted & (xx > 3), "reference")
    return test, ref, ref2


def by_hand(scene, test: Render, ref: Render, ref2: Render | None) -> dict:
    """The metrics from the libraries and the formulas themselves, not through metrics.display/psnr/ssim/flip."""
    tm = scene.tonemap
    lum = adaptation_luminance(scene.environment.radiance())
    a, b = (tonemap(x.rgb, tm.key, tm.white, tm.exposure, lum) for x in (test, ref))
    mask = binary_erosion(test.mask & ref.mask, iterations=1, border_value=0)
    mse = float(np.mean((a.astype(np.float64)[mask] - b.astype(np.float64)[mask]) ** 2))
    _, smap = structural_similarity(a.astype(np.float64), b.astype(np.float64), data_range=1.0, channel_axis=-1,
                                    full=True)
    inner = np.zeros((H, W), bool)
    inner[3:H - 3, 3:W - 3] = True
    err, _, _ = flip_evaluator.evaluate(np.ascontiguousarray(np.clip(b, 0, 1), np.float32),
                                        np.ascontiguousarray(np.clip(a, 0, 1), np.float32), "LDR",
                                        applyMagma=False, computeMeanError=False)
    flip_map = np.asarray(err, np.float64)
    flip_map = flip_map[..., 0] if flip_map.ndim == 3 else flip_map
    t, r = test.rgb.astype(np.float64)[mask], ref.rgb.astype(np.float64)[mask]
    out = {"psnr": 10.0 * math.log10(1.0 / mse), "ssim": float(smap.mean(axis=-1)[mask & inner].mean()),
           "flip": float(flip_map[mask].mean()), "rel_mse": float(np.mean((t - r) ** 2 / (r * r + 1e-2))),
           "pixels": int(mask.sum()), "display": (a, b), "mask": mask, "flip_map": flip_map,
           "ssim_map": smap.mean(axis=-1)}
    if ref2 is not None:
        b2 = tonemap(ref2.rgb, tm.key, tm.white, tm.exposure, lum)
        m2 = mask & ref2.mask
        floor = 10.0 * math.log10(1.0 / float(np.mean((b.astype(np.float64)[m2] - b2.astype(np.float64)[m2]) ** 2)))
        out["noise_floor_psnr"] = min(metrics.PSNR_CAP, floor + 10.0 * math.log10(2.0))
        out["unbiased"] = metrics.psnr_unbiased(a, b, b2, m2)
    return out


def test_measure_pair_equals_the_metrics_recomputed_independently(scene, renders):
    test, ref, ref2 = renders
    m = pair.measure_pair(test, ref, scene, second_reference=ref2)
    want = by_hand(scene, test, ref, ref2)
    np.testing.assert_array_equal(m.test, want["display"][0])
    np.testing.assert_array_equal(m.reference, want["display"][1])
    np.testing.assert_array_equal(m.mask, want["mask"])
    np.testing.assert_array_equal(m.noise_mask, want["mask"] & ref2.mask)
    assert m.psnr == pytest.approx(want["psnr"], abs=1e-12)  # the same MSE; log10 of a ratio written otherwise
    assert m.psnr == metrics.psnr(*want["display"], want["mask"])  # and bit for bit the metric function's
    assert (m.ssim, m.flip, m.rel_mse, m.pixels) == (want["ssim"], want["flip"], want["rel_mse"], want["pixels"])
    assert m.noise_floor_psnr == pytest.approx(want["noise_floor_psnr"], abs=1e-12)
    assert m.psnr_unbiased == want["unbiased"]
    np.testing.assert_array_equal(m.flip_map, want["flip_map"])
    np.testing.assert_array_equal(m.ssim_map, want["ssim_map"])
    assert m.ssim == float(m.ssim_map[m.ssim_selection].mean())
    np.testing.assert_array_equal(m.error_map, np.abs(want["display"][0] - want["display"][1]).mean(axis=-1))
    # negative control: another pair gives other numbers, so the equalities above can fail
    other = by_hand(scene, _render(test.rgb * 1.2, test.mask), ref, ref2)
    assert (other["psnr"], other["ssim"], other["flip"]) != (m.psnr, m.ssim, m.flip)


def test_compare_reports_the_measurement_as_the_metric_functions_give_it(scene, renders):
    """`compare`'s dict, key for key, as the metric functions called one by one give it."""
    test, ref, ref2 = renders
    got = comparison.compare(test, ref, scene, ref2)
    a, b, b2 = (metrics.display(scene, x.rgb) for x in renders[:1] + (ref, ref2))
    mask = metrics.common_mask(test.mask, ref.mask)
    unbiased = metrics.psnr_unbiased(a, b, b2, mask & ref2.mask)
    psnr = metrics.psnr(a, b, mask)
    floor = metrics.noise_floor_psnr(b, b2, mask & ref2.mask)
    want = {"scene": scene.name, "psnr": psnr, "psnr_unbiased": unbiased.value,
            "psnr_unbiased_clamped": unbiased.clamped, "ssim": metrics.ssim(a, b, mask),
            "flip": metrics.flip(a, b, mask), "rel_mse": metrics.rel_mse(test.rgb, ref.rgb, mask),
            "noise_floor_psnr": floor, "at_noise_floor": bool(psnr >= floor - comparison.AT_FLOOR_DB),
            "realtime_ms": {"filter": 1.0, "draw": 2.0, "total": 3.0, "render": 5000.0},
            "reference_s": 5.0, "reference_spp": 16, "reference_cache": None, "pixels": int(mask.sum()),
            "unsimulated_effects": ["x"]}
    assert got == want
    assert json.dumps(got, allow_nan=False)
    # without a second reference of a reference that is not Mitsuba's: noise-free, floor at the cap
    free = comparison.compare(test, _render(ref.rgb, ref.mask, "quadrature"), scene)
    assert free["noise_floor_psnr"] == metrics.PSNR_CAP and free["psnr_unbiased"] != got["psnr_unbiased"]


def test_the_gate_noise_estimates_reuse_the_maps_without_changing_them(scene, renders):
    test, ref, ref2 = renders
    m = pair.measure_pair(test, ref, scene, second_reference=ref2)
    again = gate.metric_noise(m.test, m.reference, m.reference2, m.noise_mask)
    reused = gate.metric_noise(m.test, m.reference, m.reference2, m.noise_mask, ssim_map=m.ssim_map,
                               flip_map=m.flip_map)
    assert reused == again and all(v is not None for v in reused.values())
    # negative control: a wrong map given is used (so the maps are really taken from the measurement)
    wrong = gate.metric_noise(m.test, m.reference, m.reference2, m.noise_mask, ssim_map=m.ssim_map * 0.5,
                              flip_map=m.flip_map * 0.5)
    assert wrong["ssim_se"] != again["ssim_se"] and wrong["flip_se"] != again["flip_se"]


def test_ssim_full_gives_the_map_and_the_pixels_it_averages(renders):
    rng = np.random.default_rng(3)
    a, b = rng.uniform(0, 1, (H, W, 3)), rng.uniform(0, 1, (H, W, 3))
    everything = np.ones((H, W), bool)
    value, smap, sel = metrics.ssim(a, b, everything, full=True)
    assert value == metrics.ssim(a, b, everything)
    assert value == pytest.approx(structural_similarity(a, b, data_range=1.0, channel_axis=-1), abs=1e-12)
    assert sel.sum() == (H - 6) * (W - 6) and value == float(smap[sel].mean())
    assert metrics.ssim(a, b, np.zeros((H, W), bool), full=True) == (None, None, None)
    assert metrics.ssim(a[:6, :6], b[:6, :6], everything[:6, :6], full=True) == (None, None, None)


def count_expensive_steps(monkeypatch) -> dict[str, int]:
    """{step: calls so far} of the display transform, FLIP and SSIM, counted from now on."""
    calls = {"display": 0, "flip": 0, "ssim": 0}

    def counted(name, fn):
        def wrapper(*a, **k):
            calls[name] += 1
            return fn(*a, **k)
        return wrapper

    monkeypatch.setattr(metrics, "display", counted("display", metrics.display))
    monkeypatch.setattr(metrics, "flip_map", counted("flip", metrics.flip_map))
    monkeypatch.setattr(metrics, "structural_similarity", counted("ssim", metrics.structural_similarity))
    return calls


def test_each_expensive_step_runs_once_per_pair(scene, renders, monkeypatch):
    test, ref, ref2 = renders
    calls = count_expensive_steps(monkeypatch)
    comparison.compare(test, ref, scene, ref2)
    assert calls == {"display": 3, "flip": 1, "ssim": 1}


def test_a_row_keeps_its_pictures_and_arrays_from_the_measurement(scene, renders, tmp_path):
    """The row's PNGs are the measurement's images, and measured.npz gives back the real-time render,
    the mask and the error map exactly (what E1, E3 and E9 read instead of rendering again)."""
    import matplotlib.image

    from experiments.measure.results import ResultRow

    test, ref, ref2 = renders
    m = pair.measure_pair(test, ref, scene, second_reference=ref2)
    pics = images.save_comparison(tmp_path, tmp_path / "images" / "r" / "row", m, test)
    assert set(pics) == {"realtime", "reference", "error", "flip", images.ARRAYS}
    png = matplotlib.image.imread(tmp_path / pics["realtime"])
    np.testing.assert_array_equal(np.round(png[..., :3] * 255).astype(np.uint8), to_uint8(np.clip(m.test, 0, 1)))
    row = ResultRow(id="r", spec="s", overrides={}, scene="s", techniques={}, materials=[], env="e", effects=[],
                    unsimulated_effects=[], width=W, height=H, face_size=8, psnr=None, ssim=None, flip=None,
                    rel_mse=None, noise_floor_psnr=None, at_noise_floor=None, pixels=0, realtime_ms={}, images=pics)
    kept = images.load_measured(tmp_path, row)
    np.testing.assert_array_equal(kept.test.rgb, test.rgb)
    np.testing.assert_array_equal(kept.test.mask, test.mask)
    assert kept.test.meta == test.meta
    np.testing.assert_array_equal(kept.mask, m.mask)
    np.testing.assert_array_equal(kept.error, m.error_map)
    # a row written before the arrays were kept (or whose file is gone) gives None, never a wrong array
    assert images.load_measured(tmp_path, ResultRow(**{**row.__dict__, "images": {}})) is None
    (tmp_path / pics[images.ARRAYS]).unlink()
    assert images.load_measured(tmp_path, row) is None


TINY = {"camera.width": 24, "camera.height": 24, "reference.spp": 16, "realtime.timing_frames": 2,
        "realtime.warmup_frames": 1}


@pytest.mark.gl
@pytest.mark.mitsuba
def test_a_sweep_row_and_the_gate_measure_each_pair_once(tmp_path, monkeypatch):
    """run_row: one tone mapping per image, one SSIM and one FLIP (the pictures reuse them); the gate:
    the pair once, then only the noise estimates' own maps (against the second seed and the mean)."""
    import groundtruth
    from experiments.runs import rows

    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    calls = count_expensive_steps(monkeypatch)
    row = rows.run_row(tmp_path / "out", "builtin:sphere-phong", TINY)
    assert calls == {"display": 3, "flip": 1, "ssim": 1}
    # the row's numbers, recomputed from what it kept and its (cached) references
    sc = scenes.load("builtin:sphere-phong").with_overrides(TINY)
    kept = images.load_measured(tmp_path / "out", row)
    ref = groundtruth.render(sc)
    want = comparison.compare(kept.test, ref, sc)
    assert (row.psnr, row.ssim, row.flip, row.psnr_unbiased, row.noise_floor_psnr, row.pixels) == \
        (want["psnr"], want["ssim"], want["flip"], want["psnr_unbiased"], want["noise_floor_psnr"], want["pixels"])
    assert row.pixels > 0 and row.psnr < metrics.PSNR_CAP
    for k in calls:
        calls[k] = 0
    gate.measure(sc, noise=True)
    assert calls == {"display": 3, "flip": 3, "ssim": 3}
