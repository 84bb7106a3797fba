"""E5 of the paper suite: the reference's convergence, spp against noise floor and seconds.

sphere-blend rendered uncached with two seeds per spp; the noise floor is the PSNR between the two
(experiments/measure/metrics.py). Monte Carlo noise falls as 1/sqrt(spp): every 4x spp adds 6.02 dB.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import scenes
from experiments.measure import metrics
from experiments.paper.context import Context
from experiments.publish import plots
from experiments.publish.report import Section, f2, figure, md_table, paragraph, table
from groundtruth.pathtracer.reference import render, second_seed
from groundtruth.pathtracer.variant import variant_name

NUMBER = 5
TITLE = "E5 reference convergence"
SPEC = "builtin:sphere-blend"
FIGURE = "figures/e5_convergence.png"


@dataclass(frozen=True)
class Settings:
    spps: tuple[int, ...]


QUICK = Settings(spps=(16, 64, 256))
FULL = Settings(spps=(16, 64, 256, 1024, 4096))


def count_steps(settings: Settings) -> int:
    """Progress steps of `run`: one per spp."""
    return len(settings.spps)


def run(context: Context, settings: Settings) -> Section:
    """E5's renders (uncached, timed every run) and its section."""
    scene = scenes.load(SPEC).with_overrides(context.base())
    render(scene, spp=4, use_cache=False)  # compile the kernels outside the timings
    rows_out, pts = [], []
    for spp in settings.spps:
        a = render(scene, spp=spp, seed=0, use_cache=False)
        b = render(scene, spp=spp, seed=second_seed(0), use_cache=False)
        mask = metrics.common_mask(a.mask, b.mask)
        floor = metrics.noise_floor_psnr(metrics.display(scene, a.rgb), metrics.display(scene, b.rgb), mask)
        secs = float(np.median([a.timings["render"], b.timings["render"]]) / 1e3)
        pts.append((spp, floor, secs))
        rows_out.append([spp, f2(floor), f"{secs:.2f}"])
        context.progress()
    plot(pts, context.out / FIGURE)
    header = ["spp", "noise floor PSNR (dB)", "render s (median of 2)"]
    note = (f"sphere-blend at {context.common.size}x{context.common.size}, Mitsuba {variant_name()}, uncached. "
            "Every 4x spp should add 6.02 dB (Monte Carlo noise falls as 1/sqrt(spp)).")
    return Section(TITLE, [table(header, rows_out), paragraph(note), figure(FIGURE, "E5")],
                   md_table(header, rows_out) + "\n\n" + note, [FIGURE])


def plot(pts: list[tuple[int, float, float]], path) -> None:
    """Noise floor and seconds against spp, two y axes."""
    plt = plots.pyplot()
    fig, ax = plt.subplots(figsize=(6.0, 3.8))
    ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label="noise floor")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("samples per pixel")
    ax.set_ylabel("noise floor PSNR (dB)")
    ax2 = ax.twinx()
    ax2.plot([p[0] for p in pts], [p[2] for p in pts], "s--", color="tab:red", label="seconds")
    ax2.set_yscale("log")
    ax2.set_ylabel("render seconds", color="tab:red")
    ax.grid(alpha=0.3, which="both")
    plots.save(fig, path)
