"""`iblcheck sweep`: metrics and timings over a grid of configurations, resumable.

Axes are any scene keys (`--axis realtime.glossy=box,prefiltered`, repeatable) plus the shortcuts
`--face-sizes`, `--lod-biases`, `--exponents`, `--f0s`, `--envs`, `--lod-mappings`. An axis that
cannot change a configuration's image is dropped from that configuration (docs/contract.md section 4), and
the configurations left are deduplicated:
- a technique choice (`realtime.diffuse`, `realtime.glossy`, ...) matters only when the scene has
  that effect;
- a technique's own keys (`Technique.reads`: `realtime.lod_bias` for `box`,
  `realtime.prefiltered.samples` for `prefiltered`, ...) matter only where that technique runs, so
  `--axis realtime.glossy=box,prefiltered --lod-biases 0,1` sweeps the bias of the box rows only;
- the Phong exponent needs `glossy`, f0 needs `fresnel`.
The reference depends on none of the real-time keys; its cache renders it once per scene state.

Rows (experiments/measure/results.py) are appended to DIR/results.jsonl as they finish (flushed and
fsynced). A rerun skips the rows already there (by `id`) and drops a half-written last line.

Row ids are keyed by content, like the reference cache (experiments/runs/rows.py, `content_id`): a hash
of the resolved scene, the bytes of a map file and of mesh files, ROW_VERSION and the reference plugin's
version. So:
- editing the scene file, the map or a mesh and rerunning computes new rows; the old rows, whose
  content no longer matches their spec and overrides, are dropped from the store (with a warning);
- two configurations that resolve to the same content (`--face-sizes 8,8`, `a.exr,./a.exr`, an axis
  value equal to the scene's own) are one row of the plan;
- one process writes a folder at a time (results.folder_lock): a second sweep into it is refused.

Each row is rendered, measured once and pictured by `rows.run_row`, here one after the other (the
serial executor) or with `--workers N` / `--scheduler ADDRESS` on Dask, which renders the references as
tasks and keeps the real-time part (and its frame times) here (experiments/runs/dask_cluster.py); a
row whose reference failed there is written with `error` set, and the next run computes it again.
"""

from __future__ import annotations

import itertools
import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rich import progress as rp

import scenes
from experiments.measure.results import RESULTS, ResultRow, folder_lock, store_in
from experiments.publish import outputs
from experiments.publish.report import build as build_report
from experiments.publish.text import one_line
from experiments.runs.rows import (
    ROW_VERSION,
    content_id,
    file_digest,
    materials_of,
    row_id,
    run_row,
    scene_content,
    short,
    with_equal_quality,
)
from realtime.engine import technique
from scenes import InputError, SceneError
from scenes.model.scene import table_users

__all__ = ["RESULTS", "ROW_VERSION", "Axes", "configurations", "content_id", "file_digest", "materials_of", "plan",
           "row_id", "run", "run_row", "scene_content", "short", "with_equal_quality"]


class StaleRowsWarning(UserWarning):
    """Rows of results.jsonl whose scene, map or mesh changed since they were computed were dropped."""

#: the shortcut flags and the scene keys they sweep
SHORTCUTS = {"face_sizes": "realtime.face_size", "lod_biases": "realtime.lod_bias",
             "exponents": "objects.*.material.exponent", "f0s": "objects.*.material.f0",
             "envs": "environment.map", "lod_mappings": "realtime.lod_mapping"}


@dataclass
class Axes:
    face_sizes: list[int] | None = field(default_factory=lambda: [8, 16, 32, 64])
    lod_biases: list[float] | None = field(default_factory=lambda: [-1.0, 0.0, 1.0, 2.0])
    exponents: list[float] | None = None
    f0s: list[float] | None = None
    envs: list[str] | None = None
    lod_mappings: list[str] | None = None
    extra: list[tuple[str, list[Any]]] = field(default_factory=list)  # --axis KEY=V1,V2 (in order)
    technique_axes: bool = False  # --technique-axes: every technique of the scene's effects and its axes

    def grid(self) -> list[tuple[str, list[Any]]]:
        """[(scene key, values)], the shortcuts first; a key given twice keeps its last values."""
        out: dict[str, list[Any]] = {}
        for name, key in SHORTCUTS.items():
            values = getattr(self, name)
            if values:
                out[key] = list(values)
        for key, values in self.extra:
            out[key] = list(values)
        return [(k, list(dict.fromkeys(_hashable(v) for v in vs))) for k, vs in out.items()]


def _hashable(v: Any) -> Any:
    return tuple(v) if isinstance(v, list) else v


#: keys that choose what a configuration simulates: they decide which other keys matter
CHOICE_KEYS = ("realtime.diffuse", "realtime.glossy", "realtime.occlusion", "realtime.interreflection",
               "realtime.parameterization")
#: table values some choices cannot be made without (interreflected transfer needs bounces >= 1)
CHOICE_PARAMETERS = ("realtime.prt.bounces",)


def chosen_scene(scene, overrides: dict[str, Any], cache: dict | None = None):
    """`scene` with the configuration's technique choices and material types and shapes applied: what
    decides which other keys matter (the effects follow from the objects, the tables from the choices).
    Other material keys are left out: a type may refuse them (a diffuse material has no exponent)."""
    sub = {k: v for k, v in overrides.items()
           if k in CHOICE_KEYS or k in CHOICE_PARAMETERS
           or (k.startswith("objects.") and k.endswith((".material.type", ".shape")))}
    if not sub:
        return scene
    ident = json.dumps(sub, sort_keys=True, default=str)
    if cache is not None and ident in cache:
        return cache[ident]
    out = scene.with_overrides({k: (list(v) if isinstance(v, tuple) else v) for k, v in sub.items()})
    if cache is not None:
        cache[ident] = out
    return out


def relevant(scene, key: str, overrides: dict[str, Any], cache: dict | None = None) -> bool:
    """Whether `key` can change the image of `scene` with `overrides` (see the module docstring)."""
    cfg = chosen_scene(scene, overrides, cache)
    fx = cfg.effects
    if key.endswith("material.exponent"):
        return "glossy" in fx
    if key.endswith("material.f0"):
        return "fresnel" in fx
    parts = key.split(".")
    if len(parts) == 2 and parts[0] == "realtime" and parts[1] in technique.EFFECT_KEYS:
        return parts[1] in fx
    if key == "realtime.reflection":  # the mirror direction per vertex or per pixel: glossy only
        return "glossy" in fx
    if len(parts) == 3 and parts[0] == "realtime" and parts[1] in table_users(cfg.realtime):
        return table_users(cfg.realtime)[parts[1]] is not None  # a technique table: where it is read
    owner = technique.owner_of(key)
    if owner is None:
        return True
    effect, value = owner
    return effect in fx and getattr(cfg.realtime, effect) == value


def technique_choices(scene) -> list[dict[str, str]]:
    """`--technique-axes`: every valid combination of technique choices for the scene's effects
    ({"realtime.diffuse": ..., "realtime.occlusion": ...}); "none" counts as a choice for occlusion and
    interreflection (the paper's), and combinations the scene model refuses (shadow maps without the
    light array) are left out."""
    effects = [e for e in technique.EFFECT_KEYS if e in scene.effects]
    options = []
    for effect in effects:
        names = [v for (e, v) in technique.pairs() if e == effect]
        if effect in ("occlusion", "interreflection"):
            names = [technique.NOTHING, *names]
        options.append(names)
    out = []
    for values in itertools.product(*options):
        choice = {f"realtime.{e}": v for e, v in zip(effects, values, strict=True)}
        # judged with the first value of each chosen technique's own axes (interreflected transfer needs
        # its bounces >= 1, which the table's default 0 would refuse)
        sample = {k: v[0] for k, v in technique_grid(choice)}
        if _valid(scene, {k: (list(v) if isinstance(v, tuple) else v) for k, v in sample.items()}):
            out.append(choice)
    return out


def technique_grid(choice: dict[str, str]) -> list[tuple[str, list[Any]]]:
    """The axes the chosen techniques declare worth sweeping (their declarations' `axes`), with the choice itself."""
    out: list[tuple[str, list[Any]]] = [(k, [v]) for k, v in choice.items()]
    for key, value in choice.items():
        effect = key.split(".")[1]
        if value != technique.NOTHING:
            out += [(k, list(v)) for k, v in technique.declaration_of(effect, value).axes.items()]
    return out


def configurations(scene, axes: Axes) -> list[dict[str, Any]]:
    """Override dicts for `scene.with_overrides`: the product of the axes, each reduced to the keys
    that matter to it, without duplicates, in order. With `technique_axes`, the product is taken per
    combination of technique choices, over the axes of the chosen techniques only."""
    grid = axes.grid()
    if not axes.technique_axes:
        return _configurations(scene, grid, [], set())
    given = {k for k, _ in grid}
    out: list[dict[str, Any]] = []
    seen: set[str] = set()
    for choice in technique_choices(scene):
        tgrid = grid + [(k, v) for k, v in technique_grid(choice) if k not in given]
        _configurations(scene, tgrid, out, seen, check=True)
    return out


def _configurations(scene, grid, out: list, seen: set, check: bool = False) -> list[dict[str, Any]]:
    keys = [k for k, _ in grid]
    cache: dict = {}
    for values in itertools.product(*(v for _, v in grid)):
        full = dict(zip(keys, values, strict=True))
        if check and not _valid_choices(scene, full, cache):
            continue  # a choice from the command line that this combination refuses
        reduced = {k: (list(v) if isinstance(v, tuple) else v) for k, v in full.items()
                   if relevant(scene, k, full, cache)}
        ident = json.dumps(reduced, sort_keys=True)
        if ident in seen:
            continue
        seen.add(ident)
        if check and not _valid(scene, reduced):
            continue  # a generated table value the chosen techniques refuse
        out.append(reduced)
    return out


def _valid_choices(scene, overrides: dict, cache: dict) -> bool:
    try:
        chosen_scene(scene, overrides, cache)
    except SceneError:
        return False
    return True


def _valid(scene, overrides: dict) -> bool:
    try:
        scene.with_overrides(overrides)
    except SceneError:
        return False
    return True


def plan(scene_specs: list[str], axes: Axes, sets: dict | None = None) -> list[tuple[str, dict]]:
    """[(scene spec, overrides)] for every row of the sweep, in order, one per content id. Every
    scene is loaded and every configuration validated first, so bad input fails before anything
    renders."""
    return [(spec, ov) for spec, ov, _ in plan_with_ids(scene_specs, axes, sets)]


class UnusedAxisWarning(UserWarning):
    """An axis of several values that changes nothing in a scene's image was left out of its rows."""


def plan_with_ids(scene_specs: list[str], axes: Axes, sets: dict | None = None) -> list[tuple[str, dict, str]]:
    """`plan` with each row's content id: [(scene spec, overrides, id)]. An axis of two or more values that
    no configuration of a scene keeps (it changes nothing there, `relevant`) is said in one warning."""
    out, seen = [], set()
    for spec in scene_specs:
        base = scenes.load(spec)
        if sets:
            base = base.with_overrides(sets)
        configs = configurations(base, axes)
        used = {k for ov in configs for k in ov}
        unused = [k for k, values in axes.grid() if len(values) > 1 and k not in used]
        if unused:
            warnings.warn(f"{spec}: {', '.join(unused)} change nothing in this scene's image (its effects: "
                          f"{', '.join(sorted(base.effects))}); their values were left out of its rows",
                          UnusedAxisWarning, stacklevel=2)
        for ov in configs:
            full = {**(sets or {}), **ov}
            rid = content_id(base.with_overrides(ov))  # also validates (e.g. a value not implemented yet)
            if rid not in seen:
                seen.add(rid)
                out.append((spec, full, rid))
    return out


def stale(rows: list[ResultRow]) -> list[ResultRow]:
    """Rows whose spec and overrides no longer give their id (the scene file, map or a mesh changed,
    or the spec cannot be loaded any more)."""
    out = []
    for r in rows:
        if r.extra.get("image"):  # an engine image's row: its id holds the image's digest (rows.image_row_id)
            continue
        try:
            now = row_id(r.spec, r.overrides)
        except InputError:
            now = None
        if now != r.id:
            out.append(r)
    return out


def run(scene_specs: list[str], axes: Axes, out_dir: Path, sets: dict | None = None,
        report: bool = True, workers: int | None = None, scheduler: str | None = None,
        cluster=None) -> list[ResultRow]:
    """Run (or resume) a sweep into out_dir; returns all rows of results.jsonl.

    The plan is made (every scene validated) and out_dir checked before anything renders; the
    folder is locked for the whole run (a second writer is refused). `workers` (a local Dask cluster
    of that many processes), `scheduler` (a running one) or `cluster` (an experiments.runs.dask_cluster.Cluster
    already started) render the references on Dask (experiments/runs/dask_cluster.py); without them the
    rows are computed here one after the other."""
    todo_plan = plan_with_ids(scene_specs, axes, sets)
    with outputs.Outputs() as out_plan, folder_lock(out_plan.folder(out_dir, "--out")):
        store = store_in(out_dir)
        rows = drop_failed(store, drop_stale(store))
        done = {r.id for r in rows}
        if cluster is None and workers is None and scheduler is None:
            _run_rows(out_dir, store, [(s, o) for s, o, rid in todo_plan if rid not in done], len(done))
        else:
            # deferred: Dask (distributed) is a heavy optional library, loaded only for --workers/--scheduler
            from experiments.runs import dask_cluster

            with dask_cluster.maybe_cluster(workers, scheduler, cluster) as cl:
                dask_cluster.run_rows(cl, out_dir, store, [t for t in todo_plan if t[2] not in done], len(done))
        rows = store.read()
        if report:
            build_report(out_dir)
    return rows


def drop_stale(store) -> list[ResultRow]:
    """The store's rows, without the stale ones (rewritten away, with a warning)."""
    rows = store.read()
    old = stale(rows)
    if old:
        ids = {r.id for r in old}
        rows = [r for r in rows if r.id not in ids]
        store.rewrite(rows)
        warnings.warn(f"{store.path}: dropped {len(old)} rows whose scene, map or mesh changed since they were "
                      "computed (or that no longer load); they are computed again", StaleRowsWarning, stacklevel=2)
    return rows


def drop_failed(store, rows: list[ResultRow]) -> list[ResultRow]:
    """`rows` without the rows that carry an error (a Dask task that failed): rewritten away, so that
    this run computes them again and each id stays once in the file."""
    if not any(r.error for r in rows):
        return rows
    rows = [r for r in rows if not r.error]
    store.rewrite(rows)
    return rows


def _run_rows(out_dir: Path, store, todo: list[tuple[str, dict]], done: int) -> None:
    """The serial executor: each row rendered, measured and appended here, in order."""
    columns = [rp.TextColumn("[bold]sweep"), rp.BarColumn(), rp.MofNCompleteColumn(), rp.TimeElapsedColumn(),
               rp.TextColumn("eta"), rp.TimeRemainingColumn(), rp.TextColumn("{task.description}", markup=False)]
    with outputs.rich_progress(*columns, transient=False) as progress:
        task = progress.add_task("", total=done + len(todo), completed=done)
        for spec, ov in todo:
            progress.update(task, description=one_line(f"{spec} {short(ov)}", 120))
            store.append(run_row(out_dir, spec, ov))
            progress.advance(task)
