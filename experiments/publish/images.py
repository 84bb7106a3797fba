"""The pictures of a comparison: tone-mapped images, an error heat map with a colour bar, the FLIP map,
and the measured arrays the paper's figures read back (so that they never render a row again).

    save_comparison(root, folder, measured, test) -> {kind: path}   # the row's `images`
    load_measured(root, row) -> MeasuredArrays | None               # what save_comparison kept
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from experiments.measure.pair import Measurement
from experiments.measure.results import ResultRow
from experiments.publish.outputs import write_bytes
from experiments.publish.plots import pyplot, save
from scenes.model.render import Render
from scenes.model.tonemap import to_uint8

#: the row's `images` key of the measured arrays (`save_comparison`, `load_measured`)
ARRAYS = "arrays"


def save_png(path: Path, rgb01: np.ndarray) -> None:
    """An 8-bit PNG, written atomically (experiments/publish/outputs.py)."""
    import matplotlib.image  # deferred: matplotlib is heavy, loaded only when a picture is written

    path.parent.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    matplotlib.image.imsave(buf, to_uint8(np.clip(rgb01, 0, 1)), format="png")
    write_bytes(path, buf.getvalue())


def save_heatmap(path: Path, values: np.ndarray, mask: np.ndarray, label: str, vmax: float | None = None,
                 cmap: str = "inferno") -> None:
    """A masked scalar map with a colour bar (pixels outside the mask are grey)."""
    import matplotlib  # deferred: matplotlib is heavy, loaded only when a picture is written

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


def save_comparison(root: Path, folder: Path, measured: Measurement, test: Render) -> dict[str, str]:
    """The pictures and arrays of one measured pair; returns {kind: path relative to root}.

    folder/realtime.png and folder/../reference.png (shared by the rows of one reference): the display
    images; folder/error.png: `measured.error_map` (|difference| of display values, mean over RGB);
    folder/flip.png: `measured.flip_map`; folder/measured.npz (kind `ARRAYS`): the real-time render
    (linear radiance, coverage, meta) and the common mask, for `load_measured`.
    """
    save_png(folder / "realtime.png", measured.test)
    ref_path = folder.parent / "reference.png"
    if not ref_path.exists():
        save_png(ref_path, measured.reference)
    save_heatmap(folder / "error.png", measured.error_map, measured.mask, "|realtime - reference| (display)")
    save_heatmap(folder / "flip.png", measured.flip_map, measured.mask, "FLIP", vmax=1.0, cmap="magma")
    save_measured(folder / "measured.npz", measured, test)
    return {k: str(p.relative_to(root)) for k, p in (("realtime", folder / "realtime.png"), ("reference", ref_path),
                                                      ("error", folder / "error.png"), ("flip", folder / "flip.png"),
                                                      (ARRAYS, folder / "measured.npz"))}


@dataclass(frozen=True)
class MeasuredArrays:
    """What a row kept of its measurement (`save_comparison`), read back by `load_measured`.

    test: the real-time Render as rendered for the row (its `rgb`, `mask` and `meta`; no timings).
    mask: the common mask of the row's metrics (`Measurement.mask`).
    error: |test - reference| of the display values, mean over RGB (`Measurement.error_map`), float32.
    """

    test: Render
    mask: np.ndarray
    error: np.ndarray


def save_measured(path: Path, measured: Measurement, test: Render) -> None:
    """`path` (.npz, written atomically): the arrays of `MeasuredArrays` (uncompressed: zlib takes ~50 ms on
    a 192 x 192 render and saves a fifth of its size)."""
    buf = io.BytesIO()
    np.savez(buf, rgb=np.asarray(test.rgb, np.float32), coverage=np.asarray(test.mask, bool),
             meta=np.array(json.dumps(test.meta, default=str)), mask=measured.mask,
             error=np.asarray(measured.error_map, np.float32))
    write_bytes(path, buf.getvalue())


def load_measured(root: Path, row: ResultRow) -> MeasuredArrays | None:
    """The arrays `save_comparison` kept for `row` under `root` (the results folder); None for a row
    without them (written before they were kept, or a failed row) or whose file is gone."""
    rel = row.images.get(ARRAYS)
    if not rel or not (Path(root) / rel).is_file():
        return None
    with np.load(Path(root) / rel, allow_pickle=False) as z:
        test = Render(rgb=z["rgb"], mask=z["coverage"], meta=json.loads(str(z["meta"])))
        return MeasuredArrays(test, z["mask"], z["error"])
