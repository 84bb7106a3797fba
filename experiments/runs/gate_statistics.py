"""The statistics of `iblcheck gate --baseline` (experiments/runs/gate.py): how much a metric may worsen
before the reference's noise no longer explains it. Plain functions of numbers and images, no files.

The PSNR rule. With M = 10^(-PSNR/10) a run's mean squared error (display values, range 1),
s2 = 10^(-floor/10) its reference's noise variance per value (the noise floor: half the mean squared
difference of the reference's two seeds), N its covered pixels and z = 2 standard errors (one-sided
97.7 %, the convention of metrics.psnr_unbiased). A reference is r = truth + n, so
M = mean((t - truth)^2) - 2 mean((t - truth) n) + mean(n^2).

- Same reference (its pixels' digest equals the baseline's: same settings, seed, spp and variant
  make it bit-identical): n is the same noise in both runs, so M_new - M_base is the true change plus
  -2 mean((t_new - t_base) n). With pixels as sampling units (a pixel's channels may be fully
  correlated) that term has a standard deviation of at most 2 sigma rms(t_new - t_base) / sqrt(N), and
  rms(t_new - t_base) <= sqrt(M_base) + sqrt(M_new) (the triangle inequality through the common r):
      s = 2 sigma (sqrt(M_base) + sqrt(M_new)) / sqrt(N),
  with N the smaller of the two runs' covered pixels when they differ (the wider tolerance).
  The bound is loose: on sphere-phong (48 x 48, 32 spp, LOD bias 0 against 1 and -1, against the
  noise-free quadrature over 12 seeds) the term's actual spread was 1/7 to 1/10 of s.
- Different references (another seed, spp, variant or CPU): the noises are independent. Each run
  records mse_se, the standard error of its M under the reference's noise: D_p = mean over channels of
  (t - r1)^2 - (t - r2)^2 is the difference of two independent draws per pixel (pixels are independent
  with the references' box filter), so mse_se = block_se(D, 1 x 1) / sqrt(2); s = sqrt(mse_se_base^2 +
  mse_se_new^2). M - s2 is an unbiased estimate of the error against the truth (metrics.psnr_unbiased),
  so a reference with more noise (s2_new > s2_base) is expected to cost that much MSE.

A scene fails when  M_new - M_base > z s + (s2_new - s2_base),  that is when its PSNR fell below the
baseline's by more than  tolerance_db = 10 log10(1 + (z s + s2_new - s2_base) / M_base).  With the same
reference the last term is 0, and an unchanged image (delta exactly 0) always passes; with a noisier
reference the tolerance grows by the PSNR that noise alone costs (and shrinks, possibly below 0, with
a cleaner one). `--tolerance-db T` replaces the rule: fail when PSNR_base - PSNR_new > T.

SSIM and FLIP. Each run records the metric's standard error under reference noise, estimated from
its maps against the two seeds: D = map(t, r1) - map(t, r2) is the difference of two independent
draws; with 16 x 16 blocks as sampling units (SSIM's 7 x 7 window and FLIP's filters correlate
neighbours), se = block_se(D) / sqrt(2). A scene fails when SSIM fell, or FLIP rose, by more than
z sqrt(se_base^2 + se_new^2) + shift. `--tolerance-ssim`, `--tolerance-flip` replace that. The shift is
0 with the same reference; with a noisier one (fewer spp) it is what that noise alone costs the metric,
slope (s2_new - s2_base), the slope measured per run against the mean of its two seeds (a reference
with half the variance). It only widens the tolerance: a cleaner reference does not narrow it (the
measured slope is noisy, and SSIM is not linear in the variance near its constants); the PSNR's shift
is exact and signed. With the same reference this is conservative (the shared noise partly cancels);
across references it is what the noise can do, measured on sphere-phong over 32 seeds: the estimates
were 0.87 (MSE), 0.80 (FLIP) and 0.61 (SSIM) of the observed spread at 96 x 96 and 64 spp, 0.9 to 1.25
of it at 48 x 48, and an unchanged image failed against another seed's baseline in 2 to 9 % of the
pairs (z = 2 would be 2.3 %): the comparison across references is less tight, and the gate says so
(a warning line).

The comparison is strict: a worsening equal to its tolerance passes (`worsened_beyond`), so an
unchanged image (a worsening of exactly 0) passes even at a tolerance of 0.
"""

from __future__ import annotations

import math

import numpy as np

from experiments.measure import metrics

#: standard errors a worsening must exceed to fail (metrics.UNBIASED_FLOOR_SE: one-sided 97.7 %)
Z = 2.0
#: the side of the blocks that are the sampling units of the SSIM/FLIP standard errors
BLOCK = 16


def block_se(diff: np.ndarray, sel: np.ndarray, block: int = BLOCK) -> float | None:
    """The standard error of mean(diff[sel]), with `block` x `block` tiles as the sampling units.

    With S_b the sum of diff over the selected pixels of tile b, c_b their count, n = sum c_b and
    D = sum S_b / n (a ratio estimator): se = sqrt(B / (B - 1) * sum_b (S_b - c_b D)^2) / n over the B
    tiles with a selected pixel. None with fewer than 2 such tiles.
    """
    sums, counts = [], []
    h, w = sel.shape
    for y in range(0, h, block):
        for x in range(0, w, block):
            m = sel[y:y + block, x:x + block]
            if m.any():
                sums.append(float(np.asarray(diff[y:y + block, x:x + block], np.float64)[m].sum()))
                counts.append(int(m.sum()))
    if len(sums) < 2:
        return None
    s, c = np.array(sums), np.array(counts, np.float64)
    n = c.sum()
    mean = s.sum() / n
    return float(math.sqrt(len(s) / (len(s) - 1) * float(((s - c * mean) ** 2).sum())) / n)


def metric_noise(test: np.ndarray, reference: np.ndarray, reference2: np.ndarray, mask: np.ndarray, *,
                 ssim_map: np.ndarray | None = None, flip_map: np.ndarray | None = None) -> dict:
    """How the reference's noise moves the metrics of `test` (display values; module docstring):
    `mse_se`, `ssim_se`, `flip_se`, the standard errors, from the maps against two independently seeded
    references; `ssim_noise_slope`, `flip_noise_slope`, the change of the metric per unit of noise
    variance, from the reference against the mean of both (half the variance). None where it cannot
    be estimated (too few pixels, a noise-free reference).

    `ssim_map`, `flip_map`: the maps of (test, reference) already computed (`pair.Measurement`), so
    that they are not computed again; computed here when None."""
    out = dict.fromkeys(("mse_se", "ssim_se", "flip_se", "ssim_noise_slope", "flip_noise_slope"))
    if not mask.any():
        return out
    t, r1, r2 = (np.asarray(x, np.float64) for x in (test, reference, reference2))
    half = (r1 + r2) / 2  # a reference with half the noise variance
    variance = float(np.mean(((r1 - r2) ** 2)[mask])) / 2  # per value: 10^(-noise_floor_psnr / 10)
    se = block_se(((t - r1) ** 2 - (t - r2) ** 2).mean(axis=-1), mask, block=1)  # pixels are independent
    out["mse_se"] = None if se is None else se / math.sqrt(2)
    sel = metrics.ssim_selection(mask)
    if min(mask.shape) >= metrics.SSIM_WINDOW and sel.any():
        one = ssim_map if ssim_map is not None else metrics.ssim(t, r1, mask, full=True).map
        two, mid = metrics.ssim(t, r2, mask, full=True).map, metrics.ssim(t, half, mask, full=True).map
        se = block_se(one - two, sel)
        out["ssim_se"] = None if se is None else se / math.sqrt(2)
        if variance > 0:
            out["ssim_noise_slope"] = float(one[sel].mean() - mid[sel].mean()) / (variance / 2)
    f1 = flip_map if flip_map is not None else metrics.flip_map(t, r1)
    se = block_se(f1 - metrics.flip_map(t, r2), mask)
    out["flip_se"] = None if se is None else se / math.sqrt(2)
    if variance > 0:
        out["flip_noise_slope"] = float(f1[mask].mean() - metrics.flip_map(t, half)[mask].mean()) / (variance / 2)
    return out


def _mse(psnr: float) -> float:
    return 10.0 ** (-psnr / 10.0)


def psnr_tolerance_db(base: dict, new: dict, same_reference: bool, z: float = Z) -> float:
    """The PSNR drop (dB) the reference's noise can explain (module docstring, "The PSNR rule").

    `base`, `new`: {"psnr", "noise_floor_psnr", "pixels"}. The result may be negative when the new
    reference is less noisy than the baseline's (its PSNR should then rise)."""
    m_b, m_n = _mse(base["psnr"]), _mse(new["psnr"])
    v_b, v_n = _mse(base["noise_floor_psnr"]), _mse(new["noise_floor_psnr"])
    if same_reference:
        n = max(min(base["pixels"], new["pixels"]), 1)
        s = 2.0 * math.sqrt(v_b) * (math.sqrt(m_b) + math.sqrt(m_n)) / math.sqrt(n)
        shift = 0.0
    else:
        s = math.sqrt((base.get("mse_se") or 0.0) ** 2 + (new.get("mse_se") or 0.0) ** 2)
        shift = v_n - v_b
    return 10.0 * math.log10(max(1.0 + (z * s + shift) / m_b, 1e-12))


def metric_tolerance(base_se: float | None, new_se: float | None, z: float = Z, shift: float = 0.0) -> float:
    """z sqrt(se_base^2 + se_new^2) + shift for SSIM or FLIP (an unknown standard error counts as 0);
    `shift`: the worsening that the new reference's other noise level alone explains (noise_shift)."""
    return z * math.sqrt((base_se or 0.0) ** 2 + (new_se or 0.0) ** 2) + shift


def noise_shift(metric: str, base: dict, new: dict) -> float:
    """The worsening of `metric` (ssim or flip) that a noisier new reference explains: slope (s2_new -
    s2_base) with the mean of the runs' `METRIC_noise_slope`, when that is a worsening, else 0 (a cleaner
    reference never narrows the tolerance: the measured slope is noisy, and SSIM is not linear in the
    variance near its constants). 0 without both floors or any slope."""
    slopes = [x[f"{metric}_noise_slope"] for x in (base, new) if x.get(f"{metric}_noise_slope") is not None]
    if not slopes or base.get("noise_floor_psnr") is None or new.get("noise_floor_psnr") is None:
        return 0.0
    change = sum(slopes) / len(slopes) * (_mse(new["noise_floor_psnr"]) - _mse(base["noise_floor_psnr"]))
    return max(-change if metric == "ssim" else change, 0.0)


def worsened_beyond(baseline: float, new: float, worse: int, tolerance: float) -> bool:
    """True when `new` is worse than `baseline` by more than `tolerance` (`worse`: -1 when a lower value is
    worse, as PSNR and SSIM; +1 when a higher one is, as FLIP). A worsening equal to the tolerance passes."""
    return (new - baseline) * worse > tolerance
