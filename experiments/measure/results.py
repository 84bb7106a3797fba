"""The experiments' data model: one typed row per compared configuration, and its JSONL store.

Sweeps, the paper suite, the report and the plots all read and write rows through this module (and
nothing else imports the sweep or the report for their data).

A row records what produced it — the scene spec and overrides, the real-time techniques with their
parameters (`realtime.engine.technique.describe`), every object's material (the fields its type uses) and
the environment — and what was measured: the metrics of `experiments.measure.comparison.compare` and the
real-time timings (medians in `realtime_ms`, p90 in `realtime_p90_ms`, both with every per-frame key
of the techniques plus `precompute`), with the host and GL renderer that timed them (`host`,
`gl_renderer`: rows of a Dask run come from many machines' references but one machine's frames). A
row whose reference failed on a Dask cluster (experiments/runs/dask_cluster.py) has `error` set and no
metrics; the next run of the sweep computes it again.

Store (`ResultStore`): `results.jsonl`, one JSON object per line, appended and fsynced as rows
finish. Reading drops a half-written last line (a killed run) so that a rerun resumes without losing
or duplicating a row; a complete line that does not parse, whose values have the wrong types
(checked against the field annotations) or whose numbers have no meaning (a negative PSNR, SSIM above
1, metrics of 0 pixels, a negative time: experiments/measure/fields.py) is an error naming the file,
the line and the field (exit 2).

A row's `id` is a hash of the content that determines it (experiments/runs/sweep.py: the resolved scene,
the map's and meshes' bytes), so an edited scene or map never resumes into old numbers.

`folder_lock(folder)`: one writer per results folder at a time (fcntl on the folder itself); a
second sweep, paper run or report into the same folder is refused.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import types
import typing
from collections.abc import Iterator
from dataclasses import MISSING, asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from experiments.measure import fields as fields_
from scenes import InputError
from scenes.model import technique_registry
from scenes.storage.files import write_bytes

RESULTS = "results.jsonl"
#: the numbers of a row whose meaning is checked on reading (experiments/measure/fields.py), beside
#: `pixels` and the timings
ROW_NUMBERS = ("psnr", "ssim", "flip", "rel_mse", "noise_floor_psnr", "psnr_unbiased", "width", "height",
               "face_size", "reference_spp", "reference_s", "equal_quality_s")


@dataclass(frozen=True)
class ResultRow:
    id: str  # hash of the content that determines the row (sweep.content_id): its identity in the store
    spec: str  # scene file or builtin:NAME
    overrides: dict[str, Any]
    scene: str  # the scene's name
    techniques: dict[str, Any]  # realtime.engine.technique.describe(scene)
    materials: list[dict[str, Any]]  # every object's material: {"type", and the fields its type uses}
    env: str
    effects: list[str]
    unsimulated_effects: list[str]
    width: int
    height: int
    face_size: int  # the face size the real-time side used (resolved from "auto")
    psnr: float | None
    ssim: float | None
    flip: float | None
    rel_mse: float | None
    noise_floor_psnr: float | None
    at_noise_floor: bool | None
    pixels: int
    realtime_ms: dict[str, float | None]
    reference_s: float | None = None
    reference_spp: int | None = None
    reference_id: str | None = None
    reference_cache: str | None = None
    psnr_unbiased: float | None = None
    psnr_unbiased_clamped: bool | None = None
    equal_quality_s: float | None = None
    equal_quality: str | None = None  # how equal_quality_s was found: interpolated | extrapolated | ...
    realtime_p90_ms: dict[str, float | None] = field(default_factory=dict)
    experiment: str | None = None
    host: str | None = None  # the machine that rendered the real-time image and timed its frames
    gl_renderer: str | None = None  # its GL renderer and version (realtime.engine.context.renderer_name)
    error: str | None = None  # why the row has no metrics (a failed reference task); rerun computes it again
    images: dict[str, str] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)  # experiment-specific values

    # -- the paper's knobs and object 0's material, for tables and plots ----------------------------
    @property
    def lod_bias(self) -> float | None:
        return self.techniques.get("lod_bias")

    @property
    def lod_mapping(self) -> str | None:
        return self.techniques.get("lod_mapping")

    @property
    def material(self) -> str:
        return self.materials[0]["type"]

    @property
    def exponent(self) -> float | None:
        return self.materials[0].get("exponent")

    @property
    def f0(self) -> float | None:
        return self.materials[0].get("f0")

    @property
    def is_engine_image(self) -> bool:
        """An engine's image scored from a manifest (runs/image_manifest.py), not a render of iblcheck's."""
        return self.techniques.get("renderer") == "image"

    @property
    def technique_label(self) -> str:
        """A readable name of the techniques the scene's effects use, with their main parameter:
        'SH order 2', 'irradiance map 32 from 32', 'box bias 1 McGuire', 'prefiltered 64 spl', joined
        by ', ' for a scene with both effects (tables and report labels). An engine image's row
        (`is_engine_image`) is named by its label: 'image flipv'."""
        if self.is_engine_image:
            return f"image {self.techniques.get('label') or self.techniques.get('engine')}"
        effects = [e for e in ("diffuse", "glossy") if e in self.effects]
        return ", ".join(technique_registry.row_label(e, self.techniques) for e in effects)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> ResultRow:
        known = {f.name for f in fields(cls)}
        required = [f.name for f in fields(cls) if f.default is MISSING and f.default_factory is MISSING]
        missing = [name for name in required if name not in data]
        if missing:
            raise ValueError(f"missing keys {', '.join(missing[:5])}")
        kwargs = {k: v for k, v in data.items() if k in known}
        hints = typing.get_type_hints(cls)
        for name, value in kwargs.items():
            if not _matches(value, hints[name]):
                raise ValueError(f"{name} = {str(value)[:40]!r} is not {_type_name(hints[name])}")
        fields_.check(kwargs, ROW_NUMBERS, "")
        fields_.check_pixels(kwargs, "")
        for name in ("realtime_ms", "realtime_p90_ms"):
            fields_.check_timings(kwargs.get(name, {}), name)
        if not kwargs["materials"] or not all(isinstance(m.get("type"), str) for m in kwargs["materials"]):
            raise ValueError("materials must list every object's material with its type")
        extra = {k: v for k, v in data.items() if k not in known}
        if extra:
            kwargs["extra"] = {**kwargs.get("extra", {}), **extra}
        return cls(**kwargs)


def _matches(value: Any, tp: Any) -> bool:
    """Whether a JSON value has the annotated type (containers are checked item by item)."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if tp is Any:
        return True
    if origin in (typing.Union, types.UnionType):
        return any(_matches(value, a) for a in args)
    if tp is type(None):
        return value is None
    if origin is dict:
        return isinstance(value, dict) and all(isinstance(k, str) and _matches(v, args[1]) for k, v in value.items())
    if origin is list:
        return isinstance(value, list) and all(_matches(v, args[0]) for v in value)
    if tp is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if tp is int:
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, tp)


def _type_name(tp: Any) -> str:
    return str(tp).replace("typing.", "")


class ResultStore:
    """results.jsonl in a folder: append-only while a run goes, atomic when rewritten."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)

    def read(self) -> list[ResultRow]:
        """Complete rows; a half-written last line (a killed run) is cut off the file."""
        if not self.path.exists():
            return []
        data = self.path.read_bytes()
        if data and not data.endswith(b"\n"):
            data = data[: data.rfind(b"\n") + 1]
            with open(self.path, "r+b") as f:
                f.truncate(len(data))
        rows = []
        for number, line in enumerate(data.decode("utf-8", errors="replace").splitlines(), start=1):
            if not line.strip():
                continue
            try:
                data = json.loads(line)
                if not isinstance(data, dict):
                    raise ValueError(f"a JSON {type(data).__name__}, not an object")
                rows.append(ResultRow.from_dict(data))
            except (ValueError, TypeError, RecursionError) as exc:
                why = "nested too deeply" if isinstance(exc, RecursionError) else _reason(exc)
                raise InputError(f"{self.path}: line {number} is not a result row ({why}); "
                                 "remove the line or the file to rerun those configurations") from None
        return rows

    def append(self, row: ResultRow) -> None:
        line = json.dumps(row.to_dict(), allow_nan=False, sort_keys=True) + "\n"
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.path, "a") as f:
            f.write(line)
            f.flush()
            os.fsync(f.fileno())

    def rewrite(self, rows: list[ResultRow]) -> None:
        """Replace the file's rows atomically (temporary file + rename; no temporary file is left on failure)."""
        text = "".join(json.dumps(r.to_dict(), allow_nan=False, sort_keys=True) + "\n" for r in rows)
        write_bytes(self.path, text.encode("utf-8"))


def _reason(exc: Exception) -> str:
    """A short reason for a bad line, without Python's own wording for JSON errors."""
    if isinstance(exc, json.JSONDecodeError):
        return f"not JSON: {exc.msg.lower()} at column {exc.colno}"
    return str(exc)[:160]


def store_in(folder: Path) -> ResultStore:
    return ResultStore(Path(folder) / RESULTS)


class FolderBusy(InputError):
    """Another iblcheck process is writing the same results folder."""


@contextlib.contextmanager
def folder_lock(folder: Path, other: str = "choose another --out") -> Iterator[Path]:
    """Hold an exclusive lock on a results folder while writing it; FolderBusy when another process
    holds it (`other`: what else the user can do, said in the error). The lock is on the folder itself (no
    lock file is left behind) and ends with the process."""
    fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FolderBusy(f"{folder}: another iblcheck process is writing this folder; wait for it to finish "
                             f"or {other}") from None
        yield Path(folder)
    finally:
        os.close(fd)
