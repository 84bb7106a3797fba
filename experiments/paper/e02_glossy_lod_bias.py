"""E2 of the paper suite: glossy reflection from the box-filtered chain, the LOD bias that suits it.

sphere-phong with LOD-bias sweeps for N in {10, 50, 200, 1000} at several face sizes: the best bias per
(N, face size) next to McGuire's offset (realtime/engine/levels.py) and the PSNR each reaches.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from experiments.paper.context import Context
from experiments.publish import plots
from experiments.publish.report import Section, f2, figure, md_table, table
from realtime.engine import levels

NUMBER = 2
TITLE = "E2 glossy: best LOD bias per exponent and face size"
SPEC = "builtin:sphere-phong"
EXPONENTS = (10.0, 50.0, 200.0, 1000.0)
FIGURE = "figures/e2_glossy.png"


@dataclass(frozen=True)
class Settings:
    faces: tuple[int, ...]
    biases: tuple[float, ...]  # LOD biases of the paper's mapping


QUICK = Settings(faces=(32, 128), biases=(-1.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0))
FULL = Settings(faces=(16, 32, 64, 128, 256), biases=tuple(np.arange(-1.0, 7.01, 0.5).round(2).tolist()))


def count_steps(settings: Settings) -> int:
    """Progress steps of `run`: one per row (the biases and McGuire's mapping, per exponent and face)."""
    return len(EXPONENTS) * len(settings.faces) * (len(settings.biases) + 1)


def reference_plan() -> list[tuple[str, dict]]:
    """(spec, overrides) of E2's distinct references (a face size or LOD bias does not change one)."""
    return [(SPEC, {"objects.*.material.exponent": n}) for n in EXPONENTS]


def run(context: Context, settings: Settings) -> Section:
    """E2's rows through `context.row` (resumable) and its section."""
    context.prefetch(reference_plan())
    rows_out, best = [], {}
    for n in EXPONENTS:
        for s in settings.faces:
            rows = [context.row(SPEC, {"objects.*.material.exponent": n, "realtime.face_size": s,
                                       "realtime.lod_bias": b}, "E2") for b in settings.biases]
            mc = context.row(SPEC, {"objects.*.material.exponent": n, "realtime.face_size": s,
                                    "realtime.lod_mapping": "mcguire", "realtime.lod_bias": 0.0}, "E2")
            top = max(rows, key=lambda r: r.psnr if r.psnr is not None else -1e9)
            best[(n, s)] = (top, mc, rows)
            formula = levels.mcguire_offset(s, n)
            ends = (min(settings.biases), max(settings.biases))
            edge = " (edge of the range)" if top.lod_bias in ends else ""
            rows_out.append([f"{n:g}", s, f"{top.lod_bias:g}{edge}", f2(top.psnr), f"{formula:.2f}",
                             f2(mc.psnr), f2(top.noise_floor_psnr)])
    header = ["N", "face size", "best bias (paper mapping)", "PSNR at best", "McGuire offset",
              "PSNR with McGuire", "noise floor"]
    plot(best, settings, context.out / FIGURE)
    return Section(TITLE, [table(header, rows_out), figure(FIGURE, "E2")], md_table(header, rows_out), [FIGURE])


def plot(best: dict, settings: Settings, path) -> None:
    """PSNR against LOD bias, one panel per exponent, one line per face size, McGuire's offset dotted."""
    plt = plots.pyplot()
    fig, axes = plt.subplots(1, len(EXPONENTS), figsize=(4 * len(EXPONENTS), 3.4), squeeze=False)
    for j, n in enumerate(EXPONENTS):
        ax = axes[0, j]
        for s in settings.faces:
            _, _, rows = best[(n, s)]
            ax.plot([r.lod_bias for r in rows], [r.psnr for r in rows], "o-", ms=3, label=f"{s}²")
            ax.axvline(levels.mcguire_offset(s, n), color=ax.lines[-1].get_color(), ls=":", lw=0.8)
        ax.set_title(f"N = {n:g}")
        ax.set_xlabel("LOD bias (dotted: McGuire offset)")
        ax.set_ylabel("PSNR (dB)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, title="face")
    plots.save(fig, path)
