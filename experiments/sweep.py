"""`iblcheck sweep`: metrics and timings over a grid of configurations, resumable.

Axes are any scene keys (`--axis realtime.glossy=box,prefiltered`, repeatable) plus the shortcuts
`--face-sizes`, `--lod-biases`, `--exponents`, `--f0s`, `--envs`, `--lod-mappings`. An axis that
cannot change a configuration's image is dropped from that configuration (design.md section 4), and
the configurations left are deduplicated:
- a technique choice (`realtime.diffuse`, `realtime.glossy`, ...) matters only when the scene has
  that effect;
- a technique's own keys (`Technique.reads`: `realtime.lod_bias` for `box`,
  `realtime.prefiltered.samples` for `prefiltered`, ...) matter only where that technique runs, so
  `--axis realtime.glossy=box,prefiltered --lod-biases 0,1` sweeps the bias of the box rows only;
- the Phong exponent needs `glossy`, f0 needs `fresnel`.
The reference depends on none of the real-time keys; its cache renders it once per scene state.

Rows (experiments/results.py) are appended to DIR/results.jsonl as they finish (flushed and
fsynced). A rerun skips the rows already there (by `id`) and drops a half-written last line.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import comparison, images
from .results import RESULTS, ResultRow, store_in

__all__ = ["RESULTS", "Axes", "configurations", "plan", "row_id", "run", "run_row"]

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


def relevant(scene, key: str, overrides: dict[str, Any]) -> bool:
    """Whether `key` can change the image of `scene` with `overrides` (see the module docstring)."""
    from realtime import technique

    fx = scene.effects
    if key.endswith("material.exponent"):
        return "glossy" in fx
    if key.endswith("material.f0"):
        return "fresnel" in fx
    parts = key.split(".")
    if len(parts) == 2 and parts[0] == "realtime" and parts[1] in technique.EFFECT_KEYS:
        return parts[1] in fx
    owner = technique.owner_of(key)
    if owner is None:
        return True
    effect, value = owner
    chosen = overrides.get(f"realtime.{effect}", getattr(scene.realtime, effect))
    return effect in fx and chosen == value


def configurations(scene, axes: Axes) -> list[dict[str, Any]]:
    """Override dicts for `scene.with_overrides`: the product of the axes, each reduced to the keys
    that matter to it, without duplicates, in order."""
    grid = axes.grid()
    keys = [k for k, _ in grid]
    out, seen = [], set()
    for values in itertools.product(*(v for _, v in grid)):
        full = dict(zip(keys, values, strict=True))
        reduced = {k: (list(v) if isinstance(v, tuple) else v) for k, v in full.items() if relevant(scene, k, full)}
        ident = json.dumps(reduced, sort_keys=True)
        if ident not in seen:
            seen.add(ident)
            out.append(reduced)
    return out


def row_id(scene_spec: str, overrides: dict) -> str:
    text = json.dumps({"scene": scene_spec, "overrides": overrides}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def reference_id(scene_spec: str, overrides: dict) -> str:
    keep = {k: v for k, v in overrides.items() if not k.startswith("realtime.")}
    return row_id(scene_spec, keep)


def plan(scene_specs: list[str], axes: Axes, sets: dict | None = None) -> list[tuple[str, dict]]:
    """[(scene spec, overrides)] for every row of the sweep, in order. Every scene is loaded and every
    configuration validated first, so bad input fails before anything renders."""
    import scenes

    out = []
    for spec in scene_specs:
        base = scenes.load(spec)
        if sets:
            base = base.with_overrides(sets)
        for ov in configurations(base, axes):
            full = {**(sets or {}), **ov}
            base.with_overrides(ov)  # validates (e.g. a technique value that is not implemented yet)
            out.append((spec, full))
    return out


def materials_of(scene) -> list[dict[str, Any]]:
    from scenes import materials

    return [{k: (list(v) if isinstance(v, tuple) else v) for k, v in materials.used_fields(o.material).items()}
            for o in scene.objects]


def run_row(out_dir: Path, spec: str, overrides: dict, experiment: str | None = None,
            convergence_curve=None, extra: dict | None = None) -> ResultRow:
    """Render one configuration in real time and its (cached) reference, compare, save the pictures.
    With a reference `convergence_curve` (experiments.convergence.curve), the row gets
    `equal_quality_s`: the path tracer's time to the real-time image's unbiased PSNR."""
    import scenes
    from realtime import technique

    scene = scenes.load(spec).with_overrides(overrides)
    c = comparison.run(scene)
    test = c.test
    rid, ref_id = row_id(spec, overrides), reference_id(spec, overrides)
    pics = images.save_comparison(out_dir, out_dir / "images" / ref_id / rid, scene, test, c.reference, c.mask)
    m = c.metrics
    eq_s, eq_how = None, None
    if convergence_curve is not None:
        from . import convergence

        target = m["psnr_unbiased"] if m["psnr_unbiased"] is not None else m["psnr"]
        eq_s, eq_how = convergence.equal_quality_s(convergence_curve, target)
    return ResultRow(
        id=rid, spec=spec, overrides=overrides, scene=scene.name, techniques=technique.describe(scene),
        materials=materials_of(scene), env=scene.environment.map, effects=sorted(scene.effects),
        unsimulated_effects=m["unsimulated_effects"], width=scene.camera.width, height=scene.camera.height,
        face_size=test.meta["face_size"], psnr=m["psnr"], ssim=m["ssim"], flip=m["flip"], rel_mse=m["rel_mse"],
        noise_floor_psnr=m["noise_floor_psnr"], at_noise_floor=m["at_noise_floor"], pixels=m["pixels"],
        realtime_ms=m["realtime_ms"], reference_s=m["reference_s"], reference_spp=m["reference_spp"],
        reference_id=ref_id, reference_cache=m["reference_cache"], psnr_unbiased=m["psnr_unbiased"],
        psnr_unbiased_clamped=m["psnr_unbiased_clamped"], equal_quality_s=eq_s, equal_quality=eq_how,
        realtime_p90_ms={k: test.timings.get(f"{k}_p90") for k in m["realtime_ms"] if k != "precompute"},
        experiment=experiment, images=pics, extra=extra or {})


def run(scene_specs: list[str], axes: Axes, out_dir: Path, sets: dict | None = None,
        report: bool = True) -> list[ResultRow]:
    """Run (or resume) a sweep into out_dir; returns all rows of results.jsonl."""
    from rich import progress as rp

    todo_plan = plan(scene_specs, axes, sets)
    out_dir.mkdir(parents=True, exist_ok=True)
    store = store_in(out_dir)
    done = {r.id for r in store.read()}
    todo = [(s, o) for s, o in todo_plan if row_id(s, o) not in done]
    columns = [rp.TextColumn("[bold]sweep"), rp.BarColumn(), rp.MofNCompleteColumn(), rp.TimeElapsedColumn(),
               rp.TextColumn("eta"), rp.TimeRemainingColumn(), rp.TextColumn("{task.description}")]
    with rp.Progress(*columns, transient=False) as progress:
        task = progress.add_task("", total=len(done) + len(todo), completed=len(done))
        for spec, ov in todo:
            progress.update(task, description=f"{spec} {short(ov)}")
            store.append(run_row(out_dir, spec, ov))
            progress.advance(task)
    rows = store.read()
    if report:
        from . import report as report_mod

        report_mod.build(out_dir)
    return rows


def short(overrides: dict) -> str:
    return " ".join(f"{k.split('.')[-1]}={v}" for k, v in overrides.items()
                    if not k.startswith(("camera.", "reference.")))
