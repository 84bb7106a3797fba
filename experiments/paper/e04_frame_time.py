"""E4 of the paper suite: frame time by effect set and face size, the map turning (refiltered) every frame.

Not compared with a reference: each point is one real-time render timed over at least 20 frames, tone
mapping timed apart (realtime/engine/display.py) and added for the last effect set.
"""

from __future__ import annotations

from dataclasses import dataclass

import realtime
import scenes
from experiments.paper.context import Context
from experiments.publish import plots
from experiments.publish.report import Section, f2, figure, md_table, paragraph, table
from realtime.engine.context import renderer_name
from realtime.engine.display import display_ms
from scenes.model.tonemap import adaptation_luminance

NUMBER = 4
TITLE = "E4 frame time by effect set and face size"
FIGURE = "figures/e4_frame_time.png"
#: (label, scene, with tone mapping)
SETS = (("diffuse (SH9)", "builtin:sphere-diffuse", False), ("glossy (phong)", "builtin:sphere-phong", False),
        ("diffuse + glossy + Fresnel (blend)", "builtin:sphere-blend", False),
        ("blend + tone mapping", "builtin:sphere-blend", True))


@dataclass(frozen=True)
class Settings:
    faces: tuple[int, ...]


QUICK = Settings(faces=(8, 64, 256))
FULL = Settings(faces=(8, 16, 32, 64, 128, 256))


def count_steps(settings: Settings) -> int:
    """Progress steps of `run`: one per render."""
    return len(SETS) * len(settings.faces)


def run(context: Context, settings: Settings) -> Section:
    """E4's renders (timed every run: frame times are not stored as rows) and its section."""
    frames = max(context.common.frames, 20)
    rows_out, series = [], {}
    sc = None
    for label, spec, tm in SETS:
        for s in settings.faces:
            sc = scenes.load(spec).with_overrides({**context.base(), "realtime.face_size": s,
                                                   "realtime.rotate_deg_per_frame": 1.0,
                                                   "realtime.timing_frames": frames})
            r = realtime.render(sc)
            total = r.timings["total"]
            disp = None
            if tm:
                t = sc.tonemap
                disp = display_ms(r.rgb, t.key, t.white, t.exposure, adaptation_luminance(sc.environment.radiance()),
                                  frames=frames)["display"]
                total += disp
            series.setdefault(label, []).append((s, total))
            rows_out.append([label, s, f2(r.timings["filter"]), f2(r.timings["draw"]), f2(disp), f2(total)])
            context.progress()
    plot(series, context.out / FIGURE)
    header = ["effects", "face size", "filter ms", "draw ms", "tone map ms", "total ms"]
    note = (f"{context.common.size}x{context.common.size} pixels, base {sc.realtime.base_size}, median of "
            f"{frames} frames after warm-up, the environment turned 1 degree per frame; GL: {renderer_name()}.")
    return Section(TITLE, [table(header, rows_out), paragraph(note), figure(FIGURE, "E4")],
                   md_table(header, rows_out) + "\n\n" + note, [FIGURE])


def plot(series: dict, path) -> None:
    """Frame time against face size, one line per effect set, log-log."""
    plt = plots.pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for label, pts in series.items():
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=label)
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("face size")
    ax.set_ylabel("frame time (ms, median)")
    ax.set_title("Frame time by effect set (map refiltered every frame)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    plots.save(fig, path)
