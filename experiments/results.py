"""The experiments' data model: one typed row per compared configuration, and its JSONL store.

Sweeps, the paper suite, the report and the plots all read and write rows through this module (and
nothing else imports the sweep or the report for their data).

A row records what produced it — the scene spec and overrides, the real-time techniques with their
parameters (`realtime.technique.describe`), every object's material (the fields its type uses) and
the environment — and what was measured: the metrics of `experiments.comparison.compare` and the
real-time timings (medians in `realtime_ms`, p90 in `realtime_p90_ms`, both with every per-frame key
of the techniques plus `precompute`).

Store (`ResultStore`): `results.jsonl`, one JSON object per line, appended and fsynced as rows
finish. Reading drops a half-written last line (a killed run) so that a rerun resumes without losing
or duplicating a row; a complete line that does not parse is an error naming the file and the line.
"""

from __future__ import annotations

import json
import os
from dataclasses import MISSING, asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from scenes import InputError

RESULTS = "results.jsonl"


@dataclass(frozen=True)
class ResultRow:
    id: str  # hash of (spec, overrides): the row's identity in the store
    spec: str  # scene file or builtin:NAME
    overrides: dict[str, Any]
    scene: str  # the scene's name
    techniques: dict[str, Any]  # realtime.technique.describe(scene)
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
    def technique_label(self) -> str:
        """A short name of the techniques that matter to the scene: 'sh2', 'irradiance_map 32', ..."""
        t, fx, parts = self.techniques, set(self.effects), []
        if "diffuse" in fx:
            d = t.get("diffuse")
            if d == "sh":
                parts.append(f"SH order {t.get('sh_order')}" + ("" if t.get("sh_window") == "none"
                                                                 else f" {t.get('sh_window')} window"))
            elif d == "irradiance_map":
                m = t.get("irradiance_map", {})
                parts.append(f"irradiance map {m.get('size')} from {m.get('source_size')}")
            else:
                parts.append(str(d))
        if "glossy" in fx:
            g = t.get("glossy")
            if g == "box":
                parts.append(f"box bias {t.get('lod_bias'):g}" + (" McGuire" if t.get("lod_mapping") == "mcguire"
                                                                 else ""))
            elif g == "prefiltered":
                p = t.get("prefiltered", {})
                parts.append(f"prefiltered {p.get('samples')} spl" + (f" FIS bias {p.get('bias'):g}" if p.get("bias")
                                                                         else ""))
            else:
                parts.append(str(g))
        return ", ".join(parts)

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
        extra = {k: v for k, v in data.items() if k not in known}
        if extra:
            kwargs["extra"] = {**kwargs.get("extra", {}), **extra}
        return cls(**kwargs)


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
                rows.append(ResultRow.from_dict(json.loads(line)))
            except (ValueError, TypeError, AttributeError) as exc:
                raise InputError(f"{self.path}: line {number} is not a result row ({str(exc)[:120]}); "
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
        """Replace the file's rows atomically (temporary file + rename)."""
        tmp = self.path.with_suffix(".tmp")
        tmp.write_text("".join(json.dumps(r.to_dict(), allow_nan=False, sort_keys=True) + "\n" for r in rows))
        tmp.replace(self.path)


def store_in(folder: Path) -> ResultStore:
    return ResultStore(Path(folder) / RESULTS)
