"""E3 of the paper suite: Fresnel blends, the error against the viewing angle.

sphere-blend (N = 100, face size 64) for f0 in {0.02, 0.04, 0.5, 1.0}, the glossy LOD from McGuire's
mapping (so that the error left is the blend's, not a bias choice): the RMS display-space error in bands
of n.v, plotted against the viewing angle acos(n.v).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from experiments.paper.context import Context
from experiments.publish import plots
from experiments.publish.report import Section, f2, figure, md_table, paragraph, table
from groundtruth.exact import raycast

NUMBER = 3
TITLE = "E3 Fresnel blends: error against viewing angle"
SPEC = "builtin:sphere-blend"
FIGURE = "figures/e3_fresnel.png"


@dataclass(frozen=True)
class Settings:
    f0s: tuple[float, ...]
    bands: int  # bands of n.v in [0, 1]


QUICK = FULL = Settings(f0s=(0.02, 0.04, 0.5, 1.0), bands=10)


def count_steps(settings: Settings) -> int:
    """Progress steps of `run`: one per row."""
    return len(settings.f0s)


def overrides(f0: float) -> dict:
    return {"objects.*.material.f0": f0, "realtime.lod_mapping": "mcguire"}


def run(context: Context, settings: Settings) -> Section:
    """E3's rows through `context.row` (resumable) and its section."""
    context.prefetch([(SPEC, overrides(f0)) for f0 in settings.f0s])
    plt = plots.pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    rows_out = []
    edges = np.linspace(0.0, 1.0, settings.bands + 1)
    for f0 in settings.f0s:
        r = context.row(SPEC, overrides(f0), "E3")
        sc, mask, err = context.error_of(r)  # as the row measured it: nothing rendered again
        hits = raycast.cast(sc, 1)
        cos_nv = np.clip((hits.normal * -hits.direction).sum(-1)[..., 0], 0, 1)
        centres, rms = [], []
        for lo, hi in zip(edges[:-1], edges[1:], strict=True):
            sel = mask & (cos_nv >= lo) & (cos_nv < hi)
            if sel.sum() >= 5:
                centres.append(math.degrees(math.acos((lo + hi) / 2)))
                rms.append(float(np.sqrt(np.mean(err[sel] ** 2))))
        ax.plot(centres, rms, "o-", label=f"f0 = {f0:g}")
        grazing = rms[0] if centres and centres[0] > 70 else None
        rows_out.append([f"{f0:g}", f2(r.psnr), f"{r.ssim:.4f}", "-" if grazing is None else f"{grazing:.4f}",
                         f"{rms[-1]:.4f}" if rms else "-"])
    ax.set_xlabel("viewing angle from the normal (degrees)")
    ax.set_ylabel("RMS display error")
    ax.set_title("Fresnel blends: error against viewing angle")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    plots.save(fig, context.out / FIGURE)
    header = ["f0", "PSNR", "SSIM", "RMS error at grazing (n.v < 0.1)", "RMS error facing (n.v > 0.9)"]
    note = ("sphere-blend (N = 100, face size 64) with the glossy LOD from McGuire's mapping; RMS of the "
            "display-space error in bands of n.v, plotted against the viewing angle acos(n.v).")
    md = md_table(header, rows_out) + "\n\n" + note
    return Section(TITLE, [table(header, rows_out), paragraph(note), figure(FIGURE, "E3")], md, [FIGURE])
