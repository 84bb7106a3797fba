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
from scenes import InputError
from scenes.model.render import Render
from scenes.model.tonemap import to_uint8

#: the row's `images` key of the measured arrays (`save_comparison`, `load_measured`)
ARRAYS = "arrays"
#: the arrays of a measured.npz (`save_measured`)
MEASURED_ARRAYS = ("rgb", "coverage", "meta", "mask", "error")


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
    without them (written before they were kept, or a failed row) or whose file is gone.

    The file is checked as the row's results are (experiments/measure/fields.py): its path stays inside
    `root`, it is an .npz of the five arrays, `rgb` an (H, W, 3) float image of the row's size with finite
    radiance, `coverage` and `mask` (H, W) booleans, `error` (H, W) finite floats in [0, 1] (a
    difference of display values), `meta` a JSON object. Anything else is an InputError naming the file
    and the array (exit 2): the paper's figures would otherwise draw whatever the file holds."""
    rel = row.images.get(ARRAYS)
    if not rel:
        return None
    root = Path(root)
    path = root / rel
    if not path.resolve().is_relative_to(root.resolve()):
        raise InputError(f"{root / 'results.jsonl'}: row {row.id}: images.{ARRAYS} = {rel!r} leaves the results "
                         "folder")
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in MEASURED_ARRAYS if k not in z.files]
            if missing:
                raise InputError(f"{path}: measured arrays without {missing[0]!r}; delete the file to measure the "
                                 "row again")
            arrays = {k: z[k] for k in MEASURED_ARRAYS}
        meta = json.loads(str(arrays["meta"]))
    except InputError:
        raise
    except Exception as exc:  # a truncated or foreign file: np.load raises zip, pickle and value errors
        raise InputError(f"{path}: not the measured arrays of a row ({type(exc).__name__}); delete the file to "
                         "measure the row again") from None
    why = _measured_problem(arrays, meta, (row.height, row.width))
    if why:
        raise InputError(f"{path}: {why}; delete the file to measure the row again")
    test = Render(rgb=arrays["rgb"], mask=arrays["coverage"], meta=meta)
    return MeasuredArrays(test, arrays["mask"], arrays["error"])


def _measured_problem(arrays: dict[str, np.ndarray], meta: object, size: tuple[int, int]) -> str | None:
    """What is wrong with the arrays of a measured.npz for a row of `size` (H, W), or None."""
    rgb, error = arrays["rgb"], arrays["error"]
    if rgb.shape != (*size, 3) or rgb.dtype.kind != "f":
        return f"rgb holds {rgb.dtype} {rgb.shape}, not the row's {size[0]} x {size[1]} x 3 floats"
    if not np.isfinite(rgb).all():
        return "rgb holds NaN or Inf"
    for name in ("coverage", "mask"):
        if arrays[name].shape != size or arrays[name].dtype != bool:
            return f"{name} holds {arrays[name].dtype} {arrays[name].shape}, not {size[0]} x {size[1]} booleans"
    if error.shape != size or error.dtype.kind != "f":
        return f"error holds {error.dtype} {error.shape}, not {size[0]} x {size[1]} floats"
    if not np.isfinite(error).all() or (error < 0).any() or (error > 1 + 1e-6).any():
        return "error holds values outside [0, 1] (a difference of display values)"
    if not isinstance(meta, dict):
        return "meta is not a JSON object"
    return None
