"""Matplotlib figures of result rows (experiments/measure/results.py): accuracy against LOD bias and against
time, cost against size."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from experiments.measure.convergence import time_model
from experiments.measure.results import ResultRow
from experiments.publish.text import one_line


def pyplot():
    """matplotlib.pyplot on the headless Agg backend."""
    import matplotlib  # deferred: matplotlib is heavy and only figures need it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def label_text(text: object, limit: int = 60) -> str:
    """User text (a scene name) as a plot label: control characters shown as escapes and `$` escaped,
    so a name is never parsed as mathtext (an unknown command there stops the whole figure)."""
    return one_line(text, limit).replace("$", r"\$")


def save(fig, path: Path, dpi: int = 90) -> None:
    """Lay out, write and close a figure."""
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    pyplot().close(fig)


def panel_grid(n: int, width: float, height: float, cols: int = 3):
    """A figure of n panels of `width` x `height` inches, at most `cols` a row: (fig, axes (rows, cols)), the
    panels past the n-th hidden."""
    plt = pyplot()
    cols = max(1, min(n, cols))
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, height * rows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    return fig, axes


def pareto_front(times: np.ndarray, scores: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both (less time, higher score), by time."""
    order = np.lexsort((-scores, times))
    front, best = [], -np.inf
    for i in order:
        if scores[i] > best:
            front.append(i)
            best = scores[i]
    return np.asarray(front, dtype=int)


def frame_ms(r: ResultRow) -> float | None:
    """A row's frame time: every per-frame part plus the shading pass (its `total` ms; None if not timed)."""
    return r.realtime_ms.get("total")


def scatter_families(ax, rows: list[ResultRow], family: Callable[[ResultRow], str], markers: str = "o",
                     size: float = 22, order: Sequence[str] = ()) -> list[ResultRow]:
    """Unbiased PSNR against frame ms, one scatter (and legend entry) per family: the families of `order`
    in that order (each, even without points), else those of the rows sorted by name; marker k of
    `markers` for the k-th family (cycling). Returns the rows drawn (both values known)."""
    pts = [r for r in rows if r.psnr_unbiased is not None and frame_ms(r)]
    for k, fam in enumerate(order or sorted({family(r) for r in pts})):
        sel = [r for r in pts if family(r) == fam]
        ax.scatter([frame_ms(r) for r in sel], [r.psnr_unbiased for r in sel], s=size,
                   marker=markers[k % len(markers)], label=fam)
    return pts


def error_grid(cells: Sequence[Sequence[tuple[ResultRow | None, str]]], root: Path, path: Path) -> None:
    """A grid of error heat maps: cells[i][j] = (row, title); the row's |realtime - reference| image (its
    `error` image, relative to `root`) with the title above it, an empty panel for a missing row or image."""
    plt = pyplot()
    n_rows, n_cols = len(cells), max(len(c) for c in cells)
    fig, axes = plt.subplots(n_rows, n_cols, figsize=(3.3 * n_cols, 3.1 * n_rows), squeeze=False)
    for i, line in enumerate(cells):
        for j, (r, title) in enumerate(line):
            ax = axes[i, j]
            ax.axis("off")
            if r is None or "error" not in r.images:
                continue
            ax.imshow(plt.imread(Path(root) / r.images["error"]))
            ax.set_title(title, fontsize=7)
    save(fig, path)


def finish_accuracy_time_axes(ax, curve, title: str, legend_size: float = 6) -> None:
    """The path tracer's spp ladder (experiments.measure.convergence.curve; seconds from its per-spp time model)
    on an unbiased-PSNR-against-ms axes, and the axes' common dress: log time, labels, grid, legend.
    E7, E8 and E10 draw their techniques first and finish with this."""
    ladder = [(x.spp, x.seconds, x.psnr_db) for x in curve if x.psnr_db is not None]
    if ladder:
        model = time_model(curve)
        secs = [(model.per_spp_s * spp if model else sec) for spp, sec, _ in ladder]
        ax.plot([1e3 * x for x in secs], [d for _, _, d in ladder], "--", color="grey", marker="x",
                label="path tracer (spp ladder)")
    ax.set_xscale("log")
    ax.set_title(title)
    ax.set_xlabel("time per image (ms, log)")
    ax.set_ylabel("unbiased PSNR (dB)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=legend_size)


def accuracy_vs_bias(rows: list[ResultRow], path: Path) -> bool:
    """PSNR and SSIM against LOD bias, one line per face size, one column per glossy scene."""
    glossy = [r for r in rows if "glossy" in r.effects and r.psnr is not None and r.techniques.get("glossy") == "box"]

    def panel(r):  # one panel per scene and material variant, one line per face size and mapping
        return (r.scene, r.exponent, r.f0 if "fresnel" in r.effects else None, r.env)

    biases = defaultdict(set)  # only panels that actually sweep the bias (paper mapping, two biases or more)
    for r in glossy:
        if r.lod_mapping == "paper":
            biases[panel(r)].add(r.lod_bias)
    panels = sorted((k for k, b in biases.items() if len(b) >= 2), key=str)[:8]
    if not panels:
        return False
    plt = pyplot()
    fig, axes = plt.subplots(2, len(panels), figsize=(3.6 * len(panels), 6.4), squeeze=False)
    for j, key in enumerate(panels):
        series = defaultdict(list)
        for r in glossy:
            if panel(r) == key and r.lod_mapping == "paper":
                series[r.face_size].append((r.lod_bias, r.psnr, r.ssim))
        name = label_text(key[0]) + f" N={key[1]:g}" + (f" f0={key[2]:g}" if key[2] is not None else "")
        for s in sorted(series):
            pts = sorted(series[s])
            b = [p[0] for p in pts]
            axes[0, j].plot(b, [p[1] for p in pts], marker="o", label=f"{s}²")
            axes[1, j].plot(b, [p[2] for p in pts], marker="o", label=f"{s}²")
        axes[0, j].set_title(name)
        axes[0, j].set_ylabel("PSNR (dB)")
        axes[1, j].set_ylabel("SSIM")
        axes[1, j].set_xlabel("LOD bias")
        axes[0, j].legend(title="face", fontsize=8)
        for ax in axes[:, j]:
            ax.grid(alpha=0.3)
    save(fig, path)
    return True


def accuracy_vs_time(rows: list[ResultRow], path: Path) -> bool:
    """PSNR against total frame time, every configuration, the Pareto front marked."""
    pts = [r for r in rows if r.psnr is not None and r.realtime_ms.get("total")]
    if not pts:
        return False
    plt = pyplot()
    t = np.array([r.realtime_ms["total"] for r in pts])
    p = np.array([r.psnr for r in pts])
    from matplotlib.ticker import ScalarFormatter  # deferred: matplotlib, as in pyplot()

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for name in sorted({r.scene for r in pts}):  # fronts per scene: different scenes do not compete
        sel = np.flatnonzero([r.scene == name for r in pts])
        dots = ax.scatter(t[sel], p[sel], s=16, alpha=0.5, label=label_text(name))
        front = sel[pareto_front(t[sel], p[sel])]
        ax.plot(t[front], p[front], color=dots.get_facecolor()[0][:3], lw=1.4, drawstyle="steps-post")
    ax.plot([], [], color="k", lw=1.4, label="Pareto front (per scene)")
    ax.set_xscale("log")
    ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.xaxis.set_minor_formatter(ScalarFormatter())
    ax.set_xlabel("frame time, all per-frame work + draw (ms, median)")
    ax.set_ylabel("PSNR (dB)")
    ax.set_title("What accuracy costs in time")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    save(fig, path)
    return True


def cost_vs_size(rows: list[ResultRow], path: Path) -> bool:
    """Median filter and draw time against face size, log axes."""
    by = defaultdict(lambda: {"filter": [], "draw": []})
    for r in rows:
        for k in ("filter", "draw"):
            if r.realtime_ms.get(k) is not None:
                by[r.face_size][k].append(r.realtime_ms[k])
    if not by:
        return False
    plt = pyplot()
    sizes = sorted(by)
    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    for k, m in (("filter", "o"), ("draw", "s")):
        ax.plot(sizes, [np.median(by[s][k]) if by[s][k] else np.nan for s in sizes], marker=m, label=k)
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("face size (texels)")
    ax.set_ylabel("time (ms, median over configurations)")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    save(fig, path)
    return True
