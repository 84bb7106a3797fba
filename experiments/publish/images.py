"""The pictures of a comparison: tone-mapped images, an error heat map with a colour bar, the FLIP map,
and the measured arrays the paper's figures read back (so that they never render a row again).

    save_comparison(root, folder, measured, test, reference, reference2, tonemap) -> {kind: path}  # row `images`
    load_measured(root, row) -> MeasuredArrays | None               # what save_comparison kept
    load_reference(root, row) -> ReferenceArrays | None             # the reference's radiance it kept
    display_tonemap(scene) -> dict                                  # the scene's Reinhard, as the viewer applies it
"""

from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from experiments.measure import metrics
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
#: the arrays a measured.npz holds since the report's viewer (absent from rows written before)
VIEWER_ARRAYS = ("flip", "tonemap")
#: the reference's linear radiance, kept once per reference folder beside reference.png
REFERENCE_FILE = "reference.npz"
#: the largest finite float16; radiance above it is stored as it (and counted)
F16_MAX = 65504.0
#: the keys of the scene's display transform kept for the viewer (scenes/model/tonemap.py `tonemap`)
TONEMAP_KEYS = ("key", "white", "exposure", "adapt_lum")


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


def display_tonemap(scene) -> dict[str, float]:
    """The scene's display transform as the report's viewer applies it: Reinhard's key, white point and
    exposure and the adaptation luminance, the very numbers `metrics.display` used for the row's metrics
    (the environment's log-average luminance, computed once per environment by `metrics`)."""
    tm = scene.tonemap
    return {"key": float(tm.key), "white": float(tm.white), "exposure": float(tm.exposure),
            "adapt_lum": float(metrics._adaptation(scene.environment))}  # the cached value display() used


def save_comparison(root: Path, folder: Path, measured: Measurement, test: Render, reference: Render | None = None,
                    reference2: Render | None = None, tonemap: dict | None = None) -> dict[str, str]:
    """The pictures and arrays of one measured pair; returns {kind: path relative to root}.

    folder/realtime.png and folder/../reference.png (shared by the rows of one reference): the display
    images; folder/error.png: `measured.error_map` (|difference| of display values, mean over RGB);
    folder/flip.png: `measured.flip_map`; folder/measured.npz (kind `ARRAYS`): the real-time render
    (linear radiance, coverage, meta), the common mask, the error and FLIP maps and the scene's display
    transform (`tonemap`, `display_tonemap`), for `load_measured` and the report's viewer.
    folder/../reference.npz (with `reference`, once per reference folder, `save_reference`): the
    reference's linear radiance and its second seed's, float16, for the report's viewer.
    """
    save_png(folder / "realtime.png", measured.test)
    ref_path = folder.parent / "reference.png"
    if not ref_path.exists():
        save_png(ref_path, measured.reference)
    save_heatmap(folder / "error.png", measured.error_map, measured.mask, "|realtime - reference| (display)")
    save_heatmap(folder / "flip.png", measured.flip_map, measured.mask, "FLIP", vmax=1.0, cmap="magma")
    save_measured(folder / "measured.npz", measured, test, tonemap)
    if reference is not None and not (folder.parent / REFERENCE_FILE).exists():
        save_reference(folder.parent / REFERENCE_FILE, reference, reference2)
    return {k: str(p.relative_to(root)) for k, p in (("realtime", folder / "realtime.png"), ("reference", ref_path),
                                                      ("error", folder / "error.png"), ("flip", folder / "flip.png"),
                                                      (ARRAYS, folder / "measured.npz"))}


def to_float16(values: np.ndarray) -> tuple[np.ndarray, int]:
    """`values` as float16 and how many were clamped: IEEE half floats hold magnitudes up to 65504, so
    larger radiance (a sun of 1e6) is stored as +-65504 and counted, never as Inf. Finer values round
    to the nearest half (11 significant bits: a relative error of at most 2^-11 above 2^-14)."""
    values = np.asarray(values, np.float32)
    clamped = int(np.count_nonzero(np.abs(values) > F16_MAX))
    return np.clip(values, -F16_MAX, F16_MAX).astype(np.float16), clamped


def save_reference(path: Path, reference: Render, reference2: Render | None = None) -> None:
    """`path` (.npz, deflated, written atomically): the reference's linear radiance (`reference`) and the
    second seed's (`reference2`, when there is one) as float16 (`to_float16`), with the counts of values
    clamped (`reference_clamped`, `reference2_clamped`)."""
    arrays: dict[str, np.ndarray] = {}
    for name, render in (("reference", reference), ("reference2", reference2)):
        if render is None:
            continue
        half, clamped = to_float16(render.rgb)
        arrays[name], arrays[f"{name}_clamped"] = half, np.array(clamped)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    write_bytes(path, buf.getvalue())


@dataclass(frozen=True)
class MeasuredArrays:
    """What a row kept of its measurement (`save_comparison`), read back by `load_measured`.

    test: the real-time Render as rendered for the row (its `rgb`, `mask` and `meta`; no timings).
    mask: the common mask of the row's metrics (`Measurement.mask`).
    error: |test - reference| of the display values, mean over RGB (`Measurement.error_map`), float32.
    flip: the FLIP map (`Measurement.flip_map`), float32; None for a row written before it was kept.
    tonemap: the scene's display transform (`display_tonemap`); None for a row written before it was kept.
    """

    test: Render
    mask: np.ndarray
    error: np.ndarray
    flip: np.ndarray | None = None
    tonemap: dict | None = None


def save_measured(path: Path, measured: Measurement, test: Render, tonemap: dict | None = None) -> None:
    """`path` (.npz, written atomically): the arrays of `MeasuredArrays` (uncompressed: zlib takes ~50 ms on
    a 192 x 192 render and saves a fifth of its size); `tonemap` as JSON when given."""
    extra = {} if tonemap is None else {"tonemap": np.array(json.dumps({k: float(tonemap[k]) for k in TONEMAP_KEYS}))}
    buf = io.BytesIO()
    np.savez(buf, rgb=np.asarray(test.rgb, np.float32), coverage=np.asarray(test.mask, bool),
             meta=np.array(json.dumps(test.meta, default=str)), mask=measured.mask,
             error=np.asarray(measured.error_map, np.float32), flip=np.asarray(measured.flip_map, np.float32),
             **extra)
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
            arrays = {k: z[k] for k in MEASURED_ARRAYS + VIEWER_ARRAYS if k in z.files}
        meta = json.loads(str(arrays["meta"]))
        tonemap = json.loads(str(arrays["tonemap"])) if "tonemap" in arrays else None
    except InputError:
        raise
    except Exception as exc:  # a truncated or foreign file: np.load raises zip, pickle and value errors
        raise InputError(f"{path}: not the measured arrays of a row ({type(exc).__name__}); delete the file to "
                         "measure the row again") from None
    why = _measured_problem(arrays, meta, (row.height, row.width)) or _viewer_problem(arrays, tonemap,
                                                                                       (row.height, row.width))
    if why:
        raise InputError(f"{path}: {why}; delete the file to measure the row again")
    test = Render(rgb=arrays["rgb"], mask=arrays["coverage"], meta=meta)
    return MeasuredArrays(test, arrays["mask"], arrays["error"], arrays.get("flip"), tonemap)


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


def _viewer_problem(arrays: dict[str, np.ndarray], tonemap: object, size: tuple[int, int]) -> str | None:
    """What is wrong with the viewer's arrays of a measured.npz (`flip`, `tonemap`; each may be absent)."""
    flip = arrays.get("flip")
    if flip is not None:
        if flip.shape != size or flip.dtype.kind != "f":
            return f"flip holds {flip.dtype} {flip.shape}, not {size[0]} x {size[1]} floats"
        if not np.isfinite(flip).all() or (flip < 0).any() or (flip > 1 + 1e-6).any():
            return "flip holds values outside [0, 1] (FLIP)"
    if tonemap is not None:
        ok = isinstance(tonemap, dict) and set(tonemap) == set(TONEMAP_KEYS) and all(
            isinstance(tonemap[k], (int, float)) and not isinstance(tonemap[k], bool) and math.isfinite(tonemap[k])
            for k in TONEMAP_KEYS) and tonemap["white"] > 0 and tonemap["adapt_lum"] > 0 and tonemap["key"] > 0
        if not ok:
            return f"tonemap is not {{{', '.join(TONEMAP_KEYS)}}} of finite numbers (key, white, adapt_lum > 0)"
    return None


@dataclass(frozen=True)
class ReferenceArrays:
    """The reference's linear radiance a row's reference folder kept (`save_reference`), float16.

    reference, reference2: (H, W, 3) float16 (reference2 None without a second seed); clamped: how many
    values of each were above 65504 and stored as 65504 ({"reference": n, "reference2": n})."""

    path: Path
    reference: np.ndarray
    reference2: np.ndarray | None
    clamped: dict[str, int]


def reference_file(row: ResultRow) -> str | None:
    """The path (relative to the results folder) of `row`'s reference.npz: beside its reference.png."""
    png = row.images.get("reference")
    return str(Path(png).parent / REFERENCE_FILE) if png else None


def load_reference(root: Path, row: ResultRow) -> ReferenceArrays | None:
    """The reference radiance `save_comparison` kept for `row`'s reference folder under `root`; None when
    there is none (a row written before it was kept, an engine image's row). Checked as `load_measured`
    checks: inside `root`, the arrays of the row's size, finite; anything else is an InputError naming
    the file."""
    rel = reference_file(row)
    if not rel:
        return None
    root = Path(root)
    path = root / rel
    if not path.resolve().is_relative_to(root.resolve()):
        raise InputError(f"{root / 'results.jsonl'}: row {row.id}: images.reference = "
                         f"{row.images.get('reference')!r} leaves the results folder")
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except Exception as exc:  # a truncated or foreign file: np.load raises zip, pickle and value errors
        raise InputError(f"{path}: not a reference's radiance ({type(exc).__name__}); delete the file to keep it "
                         "again") from None
    size = (row.height, row.width, 3)
    for name in ("reference", "reference2"):
        a = arrays.get(name)
        if a is None and name == "reference":
            raise InputError(f"{path}: no array 'reference'; delete the file to keep it again")
        if a is not None and (a.shape != size or a.dtype != np.float16 or not np.isfinite(a).all()):
            raise InputError(f"{path}: {name} holds {a.dtype} {a.shape}, not the row's finite {size[0]} x {size[1]} "
                             "x 3 float16; delete the file to keep it again")
    clamped = {k: int(arrays.get(f"{k}_clamped", 0)) for k in ("reference", "reference2") if k in arrays}
    return ReferenceArrays(path, arrays["reference"], arrays.get("reference2"), clamped)
