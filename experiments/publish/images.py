"""The pictures of a comparison: tone-mapped images, an error heat map with a colour bar, the FLIP map."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from experiments.measure import metrics
from scenes.model.tonemap import to_uint8


def save_png(path: Path, rgb01: np.ndarray) -> None:
    """An 8-bit PNG, written atomically (experiments/publish/outputs.py)."""
    import io

    import matplotlib.image

    from experiments.publish.outputs import write_bytes

    path.parent.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    matplotlib.image.imsave(buf, to_uint8(np.clip(rgb01, 0, 1)), format="png")
    write_bytes(path, buf.getvalue())


def save_heatmap(path: Path, values: np.ndarray, mask: np.ndarray, label: str, vmax: float | None = None,
                 cmap: str = "inferno") -> None:
    """A masked scalar map with a colour bar (pixels outside the mask are grey)."""
    import matplotlib

    from experiments.publish.plots import pyplot, save

    plt = pyplot()
    data = np.ma.masked_where(~mask, values)
    top = vmax if vmax is not None else (float(values[mask].max()) if mask.any() else 1.0)
    h, w = values.shape
    fig, ax = plt.subplots(figsize=(3.2, 3.2 * h / w + 0.1), dpi=100)
    cm = matplotlib.colormaps[cmap].with_extremes(bad="#808080")
    im = ax.imshow(data, cmap=cm, vmin=0.0, vmax=max(top, 1e-6), interpolation="nearest")
    ax.set_axis_off()
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label=label)
    save(fig, path, dpi=100)


def save_comparison(root: Path, folder: Path, scene, test, reference, mask: np.ndarray) -> dict[str, str]:
    """folder/realtime.png, folder/../reference.png (shared by the rows of one reference),
    folder/error.png (|difference| of display values, mean over RGB) and folder/flip.png;
    returns {kind: path relative to root}."""
    a, b = metrics.display(scene, test.rgb), metrics.display(scene, reference.rgb)
    save_png(folder / "realtime.png", a)
    ref_path = folder.parent / "reference.png"
    if not ref_path.exists():
        save_png(ref_path, b)
    save_heatmap(folder / "error.png", np.abs(a - b).mean(axis=-1), mask, "|realtime - reference| (display)")
    save_heatmap(folder / "flip.png", metrics.flip_map(a, b), mask, "FLIP", vmax=1.0, cmap="magma")
    return {k: str(p.relative_to(root)) for k, p in (("realtime", folder / "realtime.png"), ("reference", ref_path),
                                                      ("error", folder / "error.png"), ("flip", folder / "flip.png"))}
