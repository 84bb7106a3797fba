"""`iblcheck sweep`: metrics and timings over a grid of configurations, resumable.

Axes: face size and LOD bias, plus optional exponents, f0s, environments and LOD mappings. An
axis that cannot change a scene's image is skipped (design.md section 4): no LOD-bias, exponent
or LOD-mapping axis without `glossy`, no f0 axis without `fresnel`. The reference depends only on
(scene, environment, exponent, f0); the cache (its key ignores real-time settings) renders it once.

Rows are appended to DIR/results.jsonl as they finish (flushed and fsynced). A rerun reads the
file, skips the rows already there (by `id`) and drops a half-written last line, so a sweep
killed at any point resumes without losing or duplicating a row.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from . import comparison, images

RESULTS = "results.jsonl"


@dataclass
class Axes:
    face_sizes: list[int] = field(default_factory=lambda: [8, 16, 32, 64])
    lod_biases: list[float] = field(default_factory=lambda: [-1.0, 0.0, 1.0, 2.0])
    exponents: list[float] | None = None
    f0s: list[float] | None = None
    envs: list[str] | None = None
    lod_mappings: list[str] | None = None


def configurations(scene, axes: Axes) -> Iterator[dict]:
    """Override dicts for `scene.with_overrides`, only over the axes that matter to it."""
    fx = scene.effects
    glossy, fresnel = "glossy" in fx, "fresnel" in fx
    grid = [("realtime.face_size", axes.face_sizes)]
    if axes.envs:
        grid.append(("environment.map", axes.envs))
    if glossy and axes.exponents:
        grid.append(("objects.*.material.exponent", axes.exponents))
    if fresnel and axes.f0s:
        grid.append(("objects.*.material.f0", axes.f0s))
    if glossy and axes.lod_mappings:
        grid.append(("realtime.lod_mapping", axes.lod_mappings))
    grid.append(("realtime.lod_bias", axes.lod_biases if glossy else [0.0]))
    keys = [k for k, _ in grid]
    for values in itertools.product(*(v for _, v in grid)):
        yield dict(zip(keys, values, strict=True))


def row_id(scene_spec: str, overrides: dict) -> str:
    text = json.dumps({"scene": scene_spec, "overrides": overrides}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def reference_id(scene_spec: str, overrides: dict) -> str:
    keep = {k: v for k, v in overrides.items() if not k.startswith("realtime.")}
    return row_id(scene_spec, keep)


def read_rows(path: Path) -> list[dict]:
    """Complete rows of a results file; a half-written last line (a killed run) is cut off."""
    if not path.exists():
        return []
    data = path.read_bytes()
    if data and not data.endswith(b"\n"):
        data = data[: data.rfind(b"\n") + 1]
        with open(path, "r+b") as f:
            f.truncate(len(data))
    rows = []
    for line in data.decode().splitlines():
        if line.strip():
            rows.append(json.loads(line))
    return rows


def append_row(path: Path, row: dict) -> None:
    line = json.dumps(row, allow_nan=False, sort_keys=True) + "\n"
    with open(path, "a") as f:
        f.write(line)
        f.flush()
        os.fsync(f.fileno())


def plan(scene_specs: list[str], axes: Axes, sets: dict | None = None) -> list[tuple[str, dict]]:
    """[(scene spec, overrides)] for every row of the sweep, in order."""
    import scenes

    out = []
    for spec in scene_specs:
        base = scenes.load(spec)
        if sets:
            base = base.with_overrides(sets)
        for ov in configurations(base, axes):
            out.append((spec, {**(sets or {}), **ov}))
    return out


def run_row(out_dir: Path, spec: str, overrides: dict, extra: dict | None = None) -> dict:
    """Render one configuration in real time, its (cached) reference, compare, save the pictures."""
    import scenes

    scene = scenes.load(spec).with_overrides(overrides)
    c = comparison.run(scene)
    test = c.test
    rid, ref_id = row_id(spec, overrides), reference_id(spec, overrides)
    pics = images.save_comparison(out_dir, out_dir / "images" / ref_id / rid, scene, test, c.reference, c.mask)
    rt = scene.realtime
    mat = scene.objects[0].material
    row = {
        "id": rid, "reference_id": ref_id, "spec": spec, "overrides": overrides,
        "face_size": test.meta["face_size"], "base_size": rt.base_size, "lod_bias": rt.lod_bias,
        "lod_mapping": rt.lod_mapping, "material": mat.type, "exponent": mat.exponent, "f0": mat.f0,
        "env": scene.environment.map, "effects": sorted(scene.effects),
        "width": scene.camera.width, "height": scene.camera.height,
        "realtime_p90_ms": {k: test.timings.get(f"{k}_p90") for k in ("filter", "draw", "total")},
        "images": pics, **c.metrics, **(extra or {}),
    }
    return row


def run(scene_specs: list[str], axes: Axes, out_dir: Path, sets: dict | None = None, report: bool = True) -> list[dict]:
    """Run (or resume) a sweep into out_dir; returns all rows of results.jsonl."""
    from rich import progress as rp

    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / RESULTS
    done = {r["id"] for r in read_rows(path)}
    todo = [(s, o) for s, o in plan(scene_specs, axes, sets) if row_id(s, o) not in done]
    columns = [rp.TextColumn("[bold]sweep"), rp.BarColumn(), rp.MofNCompleteColumn(), rp.TimeElapsedColumn(),
               rp.TextColumn("eta"), rp.TimeRemainingColumn(), rp.TextColumn("{task.description}")]
    with rp.Progress(*columns, transient=False) as progress:
        task = progress.add_task("", total=len(done) + len(todo), completed=len(done))
        for spec, ov in todo:
            progress.update(task, description=f"{spec} {short(ov)}")
            append_row(path, run_row(out_dir, spec, ov))
            progress.advance(task)
    rows = read_rows(path)
    if report:
        from . import report as report_mod

        report_mod.build(out_dir)
    return rows


def short(overrides: dict) -> str:
    return " ".join(f"{k.split('.')[-1]}={v}" for k, v in overrides.items()
                    if not k.startswith(("camera.", "reference.")))
