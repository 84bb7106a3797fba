"""experiments.convergence: equal_quality_s on curves that follow the Monte Carlo law, and a real ladder."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from experiments.measure import convergence
from experiments.measure.convergence import Rung
from scenes.model.render import Render

SPPS = (4, 16, 64, 256, 1024, 4096)
A_DB, B_S = 20.0, 0.003  # dB = A + 10 log10(spp), seconds = B * spp


def law_curve(fixed_s: float = 0.0, a_db: float = A_DB) -> list[Rung]:
    return [Rung(spp=s, seconds=fixed_s + B_S * s, psnr_db=a_db + 10 * math.log10(s), pixels=100) for s in SPPS]


def analytic_s(db: float, a_db: float = A_DB) -> float:
    return B_S * 10 ** ((db - a_db) / 10)


@pytest.mark.parametrize(("db", "how"), [(28.0, "interpolated"), (38.5, "interpolated"), (A_DB + 10 * math.log10(64),
                                         "interpolated"), (60.0, "extrapolated"), (95.0, "extrapolated"),
                                         (20.0, "extrapolated_below"), (5.0, "extrapolated_below")])
def test_monte_carlo_law_gives_the_analytic_time(db, how):
    seconds, found = convergence.equal_quality_s(law_curve(), db)
    assert found == how
    assert seconds == pytest.approx(analytic_s(db), rel=1e-9)


def test_fixed_overhead_is_left_out_and_reported():
    """seconds = 2 s + B spp: the slope is B, the 2 s (scene build, JIT) are fixed_s."""
    rungs = law_curve(fixed_s=2.0)
    model = convergence.time_model(rungs)
    assert model.per_spp_s == pytest.approx(B_S) and model.fixed_s == pytest.approx(2.0)
    assert convergence.equal_quality_s(rungs, 40.0)[0] == pytest.approx(analytic_s(40.0))


def test_one_rung_paying_the_jit_compile_does_not_move_the_slope():
    for k in (0, len(SPPS) - 1):  # the first rendered, or the reference rendered first by another process
        rungs = law_curve()
        rungs[k] = Rung(spp=rungs[k].spp, seconds=rungs[k].seconds + 3.0, psnr_db=rungs[k].psnr_db, pixels=100)
        assert convergence.time_model(rungs).per_spp_s == pytest.approx(B_S)


def test_monotone_in_the_target_psnr():
    noisy = law_curve()
    noisy[2] = Rung(spp=64, seconds=B_S * 64, psnr_db=noisy[1].psnr_db - 1.0, pixels=100)  # a rung that dips
    for rungs in (law_curve(), noisy):
        times = [convergence.equal_quality_s(rungs, db)[0] for db in np.linspace(0.0, 100.0, 1001)]
        assert all(t is not None and math.isfinite(t) for t in times)
        assert all(t2 >= t1 for t1, t2 in zip(times, times[1:], strict=False))
        assert times[0] < times[-1]


def test_none_and_empty_inputs():
    assert convergence.equal_quality_s(None, 30.0) == (None, "no_curve")
    assert convergence.equal_quality_s([], 30.0) == (None, "no_curve")
    assert convergence.equal_quality_s(law_curve(), None) == (None, "no_psnr")
    no_pixels = [Rung(spp=4, seconds=1.0, psnr_db=None, pixels=0)]
    assert convergence.equal_quality_s(no_pixels, 30.0) == (None, "no_curve")
    assert convergence.time_model([]) is None
    assert convergence.equal_quality_s(law_curve(), 1e6) == (None, "overflow")


def test_summary_is_json_without_nan():
    for rungs in (law_curve(), [], [Rung(spp=4, seconds=0.0, psnr_db=None, pixels=0)]):
        text = json.dumps(convergence.summary(rungs), allow_nan=False)
        assert json.loads(text)["rungs"] == [vars(r) for r in rungs]


def test_ladder_is_capped_at_the_reference_spp():
    import scenes

    scene = scenes.load("builtin:sphere-diffuse").with_overrides({"reference.spp": 1280})
    assert convergence.ladder(scene) == [4, 16, 64, 256, 1024, 1280]
    assert convergence.ladder(scene, max_spp=64) == [4, 16, 64]
    assert convergence.ladder(scene, spps=[64, 4, 16, 8192]) == [4, 16, 64]
    assert convergence.ladder(scene.with_overrides({"reference.spp": 4096})) == list(SPPS)


def test_curve_renders_two_seeds_per_rung_and_reads_the_render_time(monkeypatch):
    """The plumbing, with a fake reference: truth + noise of variance 1 / spp in linear radiance."""
    import scenes
    from groundtruth.pathtracer import reference

    scene = scenes.load("builtin:sphere-diffuse").with_overrides({"camera.width": 48, "camera.height": 48})
    calls = []

    def fake_render(scene, spp=None, seed=None, use_cache=True):
        calls.append((spp, seed))
        rgb = 0.5 + np.random.default_rng(seed * 7919 + spp).normal(0, 0.05 / math.sqrt(spp), (48, 48, 3))
        mask = np.zeros((48, 48), bool)
        mask[8:40, 8:40] = True
        return Render(rgb=rgb.astype(np.float32), mask=mask, timings={"render": 10.0 * spp},
                      meta={"cache": "hit", "spp": spp, "seed": seed})

    monkeypatch.setattr(reference, "render", fake_render)
    ticks = []
    rungs = convergence.curve(scene, spps=[4, 16, 64], progress=lambda: ticks.append(1))
    seed = scene.reference.seed
    assert calls == [(s, k) for s in (4, 16, 64) for k in (seed, reference.second_seed(seed))]
    assert len(ticks) == 3
    assert [r.seconds for r in rungs] == pytest.approx([0.04, 0.16, 0.64])
    assert [r.pixels for r in rungs] == [30 * 30] * 3 and {r.cache for r in rungs} == {"hit"}
    assert all(r2.psnr_db > r1.psnr_db for r1, r2 in zip(rungs, rungs[1:], strict=False))


@pytest.mark.mitsuba
@pytest.mark.slow
def test_real_ladder_follows_the_monte_carlo_law(monkeypatch, tmp_path):
    """sphere-diffuse at 32x32, spp 4, 16, 64: each 4x spp adds 10 log10(4) = 6.02 dB (within 1.5 dB)."""
    import scenes

    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    scene = scenes.load("builtin:sphere-diffuse").with_overrides({"camera.width": 32, "camera.height": 32})
    rungs = convergence.curve(scene, spps=[4, 16, 64])
    assert [r.spp for r in rungs] == [4, 16, 64]
    assert all(r.cache == "miss" and r.seconds > 0 and r.pixels > 100 for r in rungs)
    steps = np.diff([r.psnr_db for r in rungs])
    assert steps == pytest.approx([10 * math.log10(4)] * 2, abs=1.5)
    seconds, how = convergence.equal_quality_s(rungs, rungs[1].psnr_db)
    assert how == "interpolated" and seconds == pytest.approx(convergence.time_model(rungs).per_spp_s * 16)
    assert [r.psnr_db for r in convergence.curve(scene, spps=[4, 16, 64])] == [r.psnr_db for r in rungs]  # cached


# A curve off the Monte Carlo law, by hand: 20, 30, 35 dB at 10, 100, 1000 spp (10 dB per decade, then 5),
# 0.01 s per spp. Between rungs the spp is interpolated linearly in (log10 spp, dB); outside them the law
# (10 dB per decade) goes on from the nearest rung, whatever the curve's own slope there.
HAND = [Rung(spp=10, seconds=0.1, psnr_db=20.0, pixels=100), Rung(spp=100, seconds=1.0, psnr_db=30.0, pixels=100),
        Rung(spp=1000, seconds=10.0, psnr_db=35.0, pixels=100)]


@pytest.mark.parametrize(("db", "seconds", "how"), [
    (20.0, 0.1, "interpolated"),          # exactly the first rung: reached there, not extrapolated below it
    (35.0, 10.0, "interpolated"),         # exactly the last rung: reached there, not extrapolated past it
    (30.0, 1.0, "interpolated"),          # a rung
    (25.0, 0.01 * 10**1.5, "interpolated"),   # half-way in dB from 10 to 100 spp: 10^1.5 spp (not 55)
    (32.5, 0.01 * 10**2.5, "interpolated"),   # half-way from 100 to 1000: 10^2.5 spp
    (45.0, 0.01 * 10**4, "extrapolated"),     # 10 dB past 35 at 10 dB per decade: 10^4 spp (not the curve's 10^5)
    (10.0, 0.01 * 10**0, "extrapolated_below"),   # 10 dB below 20: 1 spp
])
def test_equal_quality_on_a_curve_off_the_law_by_hand(db, seconds, how):
    """equal_quality_s on HAND: the seconds and how, computed by hand above (docstring of spp_for_psnr)."""
    got, found = convergence.equal_quality_s(HAND, db)
    assert found == how
    assert got == pytest.approx(seconds, rel=1e-9)


@pytest.mark.parametrize(("db", "spp"), [(29.0, 10**1.9), (30.0, 100.0), (35.0, 10**3.5)])
def test_a_dipping_rung_is_read_on_the_running_maximum_by_hand(db, spp):
    """Rungs 20, 30, 28, 40 dB at 10, 100, 1000, 10000 spp: the curve is the running maximum 20, 30, 30, 40,
    so 35 dB is half-way from (1000, 30) to (10000, 40) in dB, 10^3.5 spp (the raw 28 would give 10^(3 + 7/12));
    30 dB is first reached at 100 spp; 29 dB is 0.9 of the way from 10 to 100 spp (10^1.9)."""
    rungs = [Rung(spp=s, seconds=0.01 * s, psnr_db=d, pixels=100) for s, d in
             ((10, 20.0), (100, 30.0), (1000, 28.0), (10000, 40.0))]
    got, how = convergence.equal_quality_s(rungs, db)
    assert how == "interpolated"
    assert got == pytest.approx(0.01 * spp, rel=1e-9)
