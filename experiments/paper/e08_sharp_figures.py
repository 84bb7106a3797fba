"""E8's sharp-shadow part: its figures (accuracy against frame time per scene and probe, heat-map crops of the
contact shadows) and the pure choice of where to crop.

The crop: the size x size window of the largest mean of a score map (the paper's error, which is largest where it
draws no shadow at all), found exactly with a summed-area table (Crow 1984, "Summed-area tables for texture
mapping", SIGGRAPH): the sum over rows [r, r + s) and columns [c, c + s) is S[r+s, c+s] - S[r, c+s] - S[r+s, c]
+ S[r, c], with S the table padded by a zero row and column. Ties: the first window in row-major order.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from experiments.publish import plots

#: the families' markers in the scatter, in the order the families are drawn
MARKERS = "osD^v<>pP*Xh"


def crop_window(score: np.ndarray, size: int) -> tuple[int, int]:
    """(row, column) of the top-left corner of the size x size window of `score` (H, W) with the largest sum
    (module docstring); NaNs count as 0."""
    h, w = score.shape
    if not 1 <= size <= min(h, w):
        raise ValueError(f"crop size {size} does not fit a {h}x{w} map")
    s = np.zeros((h + 1, w + 1))
    s[1:, 1:] = np.nan_to_num(np.asarray(score, dtype=np.float64)).cumsum(0).cumsum(1)
    sums = s[size:, size:] - s[:-size, size:] - s[size:, :-size] + s[:-size, :-size]
    r, c = np.unravel_index(int(np.argmax(sums)), sums.shape)
    return int(r), int(c)


def crop(image: np.ndarray, corner: tuple[int, int], size: int) -> np.ndarray:
    r, c = corner
    return image[r:r + size, c:c + size]


def plot(panels: Sequence[tuple[str, list, list]], family, path: Path) -> None:
    """Unbiased PSNR against frame ms, one panel per (title, rows, spp ladder), the path tracer's ladder on each."""
    fig, axes = plots.panel_grid(len(panels), 5.2, 4.4)
    for ax, (title, found, curve) in zip(axes.flat, panels, strict=False):
        plots.scatter_families(ax, found, family, markers=MARKERS, size=16)
        plots.finish_accuracy_time_axes(ax, curve, title, legend_size=5)
    plots.save(fig, path)


def plot_heat(lines: Sequence[tuple[str, np.ndarray | None, Sequence[tuple[str, np.ndarray | None]]]],
              path: Path) -> None:
    """One line per (title, reference display crop, [(column title, error crop)]): the reference's crop, then each
    technique's |realtime - reference| crop (display values) on one colour scale per line; empty panels for None."""
    plt = plots.pyplot()
    n_cols = 1 + max(len(cells) for _, _, cells in lines)
    fig, axes = plt.subplots(len(lines), n_cols, figsize=(2.6 * n_cols, 2.7 * len(lines)), squeeze=False)
    for i, (title, ref, cells) in enumerate(lines):
        for ax in axes[i]:
            ax.axis("off")
        if ref is not None:
            axes[i, 0].imshow(np.clip(ref, 0.0, 1.0))
            axes[i, 0].set_title(f"{title}\nreference", fontsize=6)
        known = [e for _, e in cells if e is not None]
        vmax = max((float(np.max(e)) for e in known), default=1.0) or 1.0
        for j, (name, err) in enumerate(cells, start=1):
            if err is None:
                continue
            im = axes[i, j].imshow(err, cmap="inferno", vmin=0.0, vmax=vmax)
            axes[i, j].set_title(name, fontsize=6)
        if known:
            fig.colorbar(im, ax=axes[i, -1], fraction=0.046, pad=0.02)
    plots.save(fig, path)
