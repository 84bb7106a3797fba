"""`iblcheck gate`: the CI image-quality gate, by thresholds and against a baseline.

Thresholds per scene: the command line's (`--min-psnr`, `--min-ssim`, `--max-flip`) override
the scene's `[gate]` table. A scene with no threshold, no baseline to compare with and none to
write is a usage error (a gate that cannot fail is no gate). Exit code 0 when every check passes, 1 when any fails
(docs/contract.md section 6); bad scenes and a bad baseline file are refused before anything renders
(exit 2). `--junit FILE` writes JUnit XML: one test case per scene, a <failure> naming each failed
check, properties with every value; `--markdown FILE` a short table for a pull-request comment.
Names are cleaned of control characters (experiments/publish/text.py: XML 1.0 cannot hold them; Markdown
cells cannot end a row or carry HTML) and every file is written atomically.

Baseline gating ("fail when this change made the image worse than main")
------------------------------------------------------------------------
`--write-baseline FILE` stores one record per scene (JSON, `FORMAT`): the metrics (PSNR, SSIM, FLIP,
the reference's noise floor, the covered pixels, the standard errors that the reference's noise gives
the MSE, SSIM and FLIP), the timings, the scene's resolved settings, and the identity of what produced
them: iblcheck's version, the techniques, the reference (spp, seed, variant, Mitsuba and plugin
versions, its cache key and a digest of its pixels), the GL renderer and a digest of the real-time
image. The file holds exactly the scenes of that run. `--baseline FILE` compares each scene with its
record.

A record's key is the scene as named on the command line (`builtin:NAME`, or the file path,
normalised): what stays the same when a change is tested. `--set` overrides do not change the key;
they are recorded, and every setting that differs from the baseline's is printed in a warning line
(`realtime.lod_bias = 3.0 (baseline 0.0)`), so a changed setting is compared with the unchanged
scene and says so.

The rule (experiments/runs/gate_statistics.py, which derives it): a scene fails when its PSNR fell, its SSIM
fell or its FLIP rose by more than the reference's noise can explain (a tolerance from the standard
errors each run records); `--tolerance-db T`, `--tolerance-ssim`, `--tolerance-flip` replace it.

Frame time (`realtime_ms.total`) is reported with its ratio to the baseline's; it fails only with
`--max-time-ratio R` and a ratio above R (machines differ).

When the identity differs (the reference, the GL renderer, the techniques, iblcheck's version or any
setting), a `warning:` line says what: the comparison is then less tight (another GL renders another
image; another reference takes the different-references branch). A scene missing from the baseline
fails, as a missing golden image does in CI (`--write-baseline` adds it); baseline scenes not run are
listed in a note. A baseline file that is missing, unreadable, not JSON, holds NaN or Infinity, a
field of the wrong type or a number without meaning (a negative standard error, a PSNR outside
[0, 100], metrics of 0 pixels, a negative time: experiments/measure/fields.py) is a `BaselineError`
naming the file and the field (exit 2).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

import groundtruth
from experiments.measure import comparison, engine_image, fields, metrics
from experiments.measure.pair import Measurement, clipped_words, measure_pair
from experiments.measure.results import ResultRow
from experiments.publish.outputs import write_bytes, write_text
from experiments.publish.text import md_cell, one_line, xml_text
from experiments.runs.gate_statistics import (
    metric_noise,
    metric_tolerance,
    noise_shift,
    psnr_tolerance_db,
    worsened_beyond,
)
from experiments.runs.rows import content_id, measured_row, scene_content
from scenes import InputError
from scenes.exchange import scene_spec
from scenes.model.render import Render
from scenes.storage.files import read_input

CHECKS = (("min_psnr", "psnr", ">="), ("min_ssim", "ssim", ">="), ("max_flip", "flip", "<="))

#: the baseline file's format marker and version (a newer version is refused, not misread)
FORMAT, VERSION = "iblcheck-gate-baseline", 1
#: a baseline file larger than this is refused before it is read
MAX_BASELINE_BYTES = 64 << 20
#: the metrics a baseline compares, and the direction in which each gets worse
BASELINE_METRICS = (("psnr", "dB", -1), ("ssim", "", -1), ("flip", "", +1))
#: a record's numbers whose meaning is checked on reading (experiments/measure/fields.py), beside `pixels`
RECORD_NUMBERS = ("psnr", "ssim", "flip", "noise_floor_psnr", "mse_se", "ssim_se", "flip_se", "ssim_noise_slope",
                  "flip_noise_slope")


class BaselineError(InputError):
    """A baseline file is missing, unreadable or malformed (exit 2)."""


@dataclass
class Delta:
    """One metric of a scene against its baseline. For `time` the delta is the ratio new / baseline."""

    metric: str
    baseline: float | None
    new: float | None
    tolerance: float | None  # the worsening allowed (dB for PSNR); for time, --max-time-ratio or None
    failed: bool = False

    @property
    def delta(self) -> float | None:
        if self.baseline is None or self.new is None:
            return None
        if self.metric == "time":
            return self.new / self.baseline if self.baseline > 0 else None
        return self.new - self.baseline


@dataclass
class GateResult:
    scene: str
    metrics: dict
    thresholds: dict
    failures: list[str] = field(default_factory=list)
    seconds: float = 0.0
    record: dict | None = None  # what --write-baseline stores for this scene
    baseline: str | None = None  # None (no baseline given), "compared" or "missing"
    deltas: list[Delta] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    row: ResultRow | None = None  # the scene's report row (`compare_all(..., report_dir=)`)

    @property
    def passed(self) -> bool:
        return not self.failures


# --------------------------------------------------------------------------- thresholds


def thresholds_for(scene, cli: dict, required: bool = True) -> dict:
    out = {k: getattr(scene.gate, k) for k, _, _ in CHECKS}
    out.update({k: v for k, v in cli.items() if v is not None})
    out = {k: v for k, v in out.items() if v is not None}
    if not out and required:
        raise InputError(f"{scene.path}: no gate thresholds: give --min-psnr/--min-ssim/--max-flip, "
                         "a [gate] table in the scene, or --baseline FILE")
    return out


def evaluate(metrics: dict, thresholds: dict, allow_empty: bool = False) -> list[str]:
    """The failures of one scene's metrics against its thresholds (empty when it passes).

    An empty comparison (`metrics["no_signal"]`, experiments/measure/pair.py: no lit pixel in the
    reference, none below white, too few covered pixels) never passes: it fails with its reason, unless
    `allow_empty` (the scene's [gate] says `allow_empty = true`), when it passes with nothing to check. A
    comparison more than `pair.CLIPPED_SHARE` of whose pixels are clipped white in the reference
    (`metrics["clipped_share"]`) fails with that reason whatever its metrics. A `min_psnr`
    above the reference's noise floor fails whatever the PSNR, with the spp that would resolve it
    (`unresolvable`)."""
    empty = metrics.get("no_signal")
    if empty:
        return [] if allow_empty else [
            f"empty comparison: {empty}; its metrics are null and it cannot pass. If this is expected, "
            "write allow_empty = true in the scene's [gate] table"]
    failures = [clipped_words(metrics["clipped_share"])] if metrics.get("clipped_share") else []
    for key, metric, op in CHECKS:
        if key not in thresholds:
            continue
        value, limit = metrics.get(metric), thresholds[key]
        if value is None:
            failures.append(f"{metric} undefined (no covered pixels), required {op} {limit:g}")
        elif (op == ">=" and value < limit) or (op == "<=" and value > limit):
            failures.append(f"{metric} = {value:.4g}, required {op} {limit:g}")
    hint = unresolvable(thresholds.get("min_psnr"), metrics.get("noise_floor_psnr"), metrics.get("reference_spp"))
    if hint:  # replaces the plain PSNR failure: the threshold itself is what is wrong
        value = metrics.get("psnr")
        head = "" if value is None else f"psnr = {value:.4g}, required >= {thresholds['min_psnr']:g}: "
        failures = [f for f in failures if not f.startswith("psnr ")] + [head + hint]
    return failures


def spp_for_floor(floor_db: float, spp: int, target_db: float) -> int:
    """The reference spp whose noise floor reaches `target_db`, a doubling of `spp` (at most 2^24).

    metrics.noise_floor_psnr is PSNR(a, b) + 10 log10(2) for two references a, b of independent seeds:
    with sigma^2 the noise variance of one reference per value, MSE(a, b) = 2 sigma^2, so the floor is
    -10 log10(sigma^2), the PSNR of one reference against the truth. A pixel's Monte Carlo estimate
    averages spp independent samples, so sigma^2 = v / spp: doubling spp halves sigma^2 and raises the
    floor by 10 log10(2) = 3.01 dB. The floor reaches target_db after
    ceil((target_db - floor_db) / (10 log10 2)) doublings."""
    doublings = max(0, math.ceil((target_db - floor_db) / metrics.TWO_RENDERS_DB - 1e-9))
    return int(min(spp * 2 ** doublings, 1 << 24))


def unresolvable(min_psnr: float | None, floor: float | None, spp: int | None) -> str | None:
    """Why `min_psnr` cannot be checked against a reference with this noise floor, or None.

    Against a reference r = truth + n, a perfect image scores exactly the floor (its MSE is n's
    variance), and any image at most about that: a threshold above the floor fails every technique,
    and the gate cannot tell a good one from a bad one. The hint names the floor and the spp at which
    the floor would reach the threshold (`spp_for_floor`)."""
    if min_psnr is None or floor is None or floor >= metrics.PSNR_CAP or min_psnr <= floor:
        return None
    need = ""
    if spp:
        more = spp_for_floor(floor, spp, min_psnr)
        reach = floor + metrics.TWO_RENDERS_DB * math.log2(more / spp)
        need = (f"; reference.spp = {more} would resolve it" if reach >= min_psnr - 1e-9 else
                f"; not even reference.spp = {more}, the most allowed, would (its floor about {reach:.0f} dB)")
    return (f"min_psnr {min_psnr:g} dB is above the reference's noise floor {floor:.2f} dB"
            + (f" at {spp} spp" if spp else "") + " (an error-free image scores about the floor against this "
            "reference's own noise, so a score above it comes from sharing that noise, as a copy of the reference "
            f"does, not from accuracy; the floor rises 3 dB per doubling of spp){need}, or lower min_psnr")


# --------------------------------------------------------------------------- loading and measuring


@dataclass
class Planned:
    """A scene to gate: as named, loaded with the --set overrides, with its thresholds and key."""

    spec: str
    scene: Any
    thresholds: dict
    sets: dict
    key: str
    image: Any = None  # an engine image (experiments.measure.engine_image.EngineImage) gated instead of a render
    label: str | None = None  # the image's manifest label (its baseline key is SCENE#LABEL)
    scene_spec: str | None = None  # the image's scene as the manifest names it

    def __iter__(self):  # unpacks as (scene, thresholds), as load() returned before baselines
        return iter((self.scene, self.thresholds))


def scene_key(spec: str) -> str:
    """The baseline key of a scene as named on the command line: builtin names as they are, file
    paths normalised (`./a.toml` and `a.toml` are one key)."""
    return spec if spec.startswith("builtin:") else os.path.normpath(spec)


def run(scene_specs: list[str], cli_thresholds: dict, sets: dict | None = None) -> list[GateResult]:
    """Load every scene first (bad input fails before any render), then compare each."""
    return compare_all(load(scene_specs, cli_thresholds, sets))


def load(scene_specs: list[str], cli_thresholds: dict, sets: dict | None = None,
         thresholds_required: bool = True) -> list[Planned]:
    """Every scene loaded and validated, with its thresholds (bad input fails before any render)."""
    loaded, keys = [], {}
    for spec in scene_specs:
        s = scene_spec.load(spec)
        s = s.with_overrides(sets) if sets else s
        key = scene_key(spec)
        if not thresholds_required and key in keys:
            raise InputError(f"{spec}: named twice (as {keys[key]!r}); a baseline holds one record per scene")
        keys[key] = spec
        loaded.append(Planned(spec, s, thresholds_for(s, cli_thresholds, thresholds_required), dict(sets or {}), key))
    return loaded


@dataclass
class Measured:
    """One scene measured: the comparison's metrics, the noise of SSIM and FLIP, the renders' meta."""

    metrics: dict
    noise: dict
    test_meta: dict
    reference_meta: dict
    digests: dict
    seconds: float
    # the pair itself, for a report of the run (`--report`, rows.measured_row); None for an engine image
    pair: Pair | None = None


@dataclass
class Pair:
    """The renders and the measurement behind a scene's metrics (what its report row keeps)."""

    test: Render
    reference: Render
    reference2: Render | None
    measurement: Measurement


def _references(scene, step: Callable[[str], None]) -> tuple[str, Render, Render | None]:
    """(the scene's name for the progress bar, its reference, its second seed), each step announced."""
    name = one_line(scene.name, 60)
    step(f"{name}: reference")
    reference = groundtruth.render(scene)
    step(f"{name}: reference, second seed")
    return name, reference, comparison.second_reference(reference, scene)


def measure(scene, step: Callable[[str], None] | None = None, noise: bool = True) -> Measured:
    """Render `scene`'s reference (and its second seed) and its real-time image, and compare them:
    comparison.run in steps, each announced to `step` (a progress bar), with the reference-noise
    standard errors of SSIM and FLIP (`metric_noise`, reusing the pair's SSIM and FLIP maps) when `noise`."""
    step = step or (lambda text: None)
    t0 = time.perf_counter()
    name, reference, reference2 = _references(scene, step)
    step(f"{name}: real-time")
    test = comparison.render_realtime(scene)
    step(f"{name}: metrics")
    m = measure_pair(test, reference, scene, second_reference=reference2)
    result = comparison.compare(test, reference, scene, reference2, measured=m)
    extra = {}
    if noise and reference2 is not None:
        extra = metric_noise(m.test, m.reference, m.reference2, m.noise_mask, ssim_map=m.ssim_map, flip_map=m.flip_map)
    digests = {"image_sha256": _digest(test.rgb, test.mask), "reference_sha256": _digest(reference.rgb, reference.mask)}
    return Measured(result, extra, dict(test.meta), dict(reference.meta), digests, time.perf_counter() - t0,
                    Pair(test, reference, reference2, m))


def measure_image(scene, image, step: Callable[[str], None] | None = None, noise: bool = True) -> Measured:
    """`measure` of an engine's image (experiments/measure/engine_image.py) instead of the real-time render."""
    step = step or (lambda text: None)
    t0 = time.perf_counter()
    name, reference, reference2 = _references(scene, step)
    step(f"{name}: image {one_line(image.path.name, 60)}")
    c = engine_image.compare_image(image, scene, reference, reference2)
    step(f"{name}: metrics")
    m = c.measured
    extra = {}
    if noise and reference2 is not None:
        extra = metric_noise(m.test, m.reference, m.reference2, m.noise_mask, ssim_map=m.ssim_map, flip_map=m.flip_map)
    digests = {"image_sha256": hashlib.sha256(image.path.read_bytes()).hexdigest()[:32],
               "reference_sha256": _digest(reference.rgb, reference.mask)}
    return Measured(c.metrics, extra, dict(c.test.meta), dict(reference.meta), digests, time.perf_counter() - t0)


def _digest(rgb: np.ndarray, mask: np.ndarray) -> str:
    h = hashlib.sha256(np.ascontiguousarray(rgb, np.float32).tobytes())
    h.update(np.ascontiguousarray(mask, bool).tobytes())
    return h.hexdigest()[:32]


def iblcheck_version() -> str:
    try:
        return metadata.version("iblcheck")
    except metadata.PackageNotFoundError:  # run from a checkout that was never installed
        return "unknown"


def make_record(planned: Planned, m: Measured) -> dict:
    """What --write-baseline stores for a scene (module docstring)."""
    ref = m.reference_meta
    record = {
        **({"key": planned.key, "image": engine_image.image_fields(planned.image), "label": planned.label,
            "scene_spec": planned.scene_spec} if planned.image is not None else {}),
        "name": planned.scene.name,
        "spec": planned.spec,
        "sets": {k: str(v) for k, v in planned.sets.items()},
        "scene_id": content_id(planned.scene),
        "settings": flatten(scene_content(planned.scene)),
        "identity": {
            "iblcheck": iblcheck_version(),
            "techniques": m.test_meta.get("techniques"),
            "gl": m.test_meta.get("gl"),
            # an external engine's image (engines/command.py or a manifest's): its name and version
            **({"engine": f"{m.test_meta.get('engine')} {m.test_meta.get('engine_version') or ''}".strip()}
               if m.test_meta.get("engine") else {}),
            "reference": {k: ref.get(k) for k in ("spp", "seed", "variant", "mitsuba", "plugin_version",
                                                  "integrator", "model", "key")},
            **m.digests,
        },
        "metrics": {**{k: m.metrics.get(k) for k in ("psnr", "ssim", "flip", "noise_floor_psnr", "psnr_unbiased",
                                                       "rel_mse", "pixels")}, **m.noise,
                    # why the metrics are null, for an empty comparison only (pair.Measurement.empty)
                    **({"no_signal": m.metrics["no_signal"]} if m.metrics.get("no_signal") else {})},
        "timings": {"realtime_ms": m.metrics.get("realtime_ms"), "reference_s": m.metrics.get("reference_s"),
                    "seconds": m.seconds},
    }
    # through JSON once, so that a fresh record equals one read back (tuples become lists)
    return json.loads(json.dumps(record, default=str, allow_nan=False))


def flatten(tree: Any, prefix: str = "") -> dict[str, Any]:
    """{"a.b.0.c": value} for a nested dict/list (the scene keys of `--set`)."""
    if isinstance(tree, dict):
        items = tree.items()
    elif isinstance(tree, (list, tuple)) and any(isinstance(v, (dict, list, tuple)) for v in tree):
        items = enumerate(tree)
    else:
        return {prefix: tree}
    out: dict[str, Any] = {}
    for k, v in items:
        out.update(flatten(v, f"{prefix}.{k}" if prefix else str(k)))
    return out


def compare_all(loaded: list, baseline: dict | None = None, tolerances: dict | None = None,
                step: Callable[[str], None] | None = None, noise: bool = True,
                report_dir: Path | None = None) -> list[GateResult]:
    """Measure every planned scene, check its thresholds and, with `baseline` (read_baseline), compare
    it with its record (`tolerances`: tolerance_db, tolerance_ssim, tolerance_flip, max_time_ratio).
    `noise=False` skips the metrics' noise estimates (a gate by thresholds alone needs none).
    `report_dir`: each scene's result row, pictures and arrays are saved there (rows.measured_row, from
    the measurement made here) and kept as `GateResult.row`, for the report `--report` writes."""
    results = []
    for p in loaded:
        p = p if isinstance(p, Planned) else Planned(p[0].path, p[0], p[1], {}, scene_key(p[0].path))
        wants_noise = noise or baseline is not None
        m = (measure(p.scene, step, wants_noise) if p.image is None
             else measure_image(p.scene, p.image, step, wants_noise))
        record = make_record(p, m)
        allow_empty = p.scene.gate.allow_empty
        name = p.scene.name if p.image is None else f"{p.scene.name} [{p.label}]"
        r = GateResult(name, m.metrics, p.thresholds, evaluate(m.metrics, p.thresholds, allow_empty),
                       m.seconds, record)
        if report_dir is not None and m.pair is not None:
            r.row = measured_row(report_dir, p.spec, p.sets, p.scene, m.metrics, m.pair.measurement, m.pair.test,
                                 m.pair.reference, m.pair.reference2)
        if allow_empty and m.metrics.get("no_signal"):
            r.warnings.append(f"empty comparison ({m.metrics['no_signal']}) passes: the scene's [gate] says "
                              "allow_empty = true")
        if baseline is not None:
            entry = baseline["scenes"].get(p.key)
            if entry is None:
                r.baseline = "missing"
                r.failures.append(f"not in the baseline {baseline['path']} (key {p.key!r}); "
                                  "--write-baseline records it")
            else:
                r.baseline = "compared"
                r.deltas, fails, r.warnings = compare_record(record, entry, tolerances or {})
                r.failures += fails
        results.append(r)
    return results


# --------------------------------------------------------------------------- the baseline rule


def identity_differences(record: dict, entry: dict) -> list[str]:
    """What differs between a run and its baseline record, as short phrases (empty when nothing does)."""
    out = []
    a, b = record.get("identity", {}), entry.get("identity", {})
    ra, rb = a.get("reference") or {}, b.get("reference") or {}
    changed = [f"{k} {ra.get(k)} (baseline {rb.get(k)})" for k in ("spp", "seed", "variant", "mitsuba",
                                                                    "plugin_version", "integrator", "model")
               if ra.get(k) != rb.get(k)]
    looser = "; the comparison with the baseline is less tight"
    if changed:
        out.append("the reference differs: " + ", ".join(changed) + looser)
    elif a.get("reference_sha256") != b.get("reference_sha256"):
        out.append("the reference has the baseline's settings but other pixels (another machine or CPU?)" + looser)
    if a.get("engine") != b.get("engine"):
        out.append(f"the engine differs: {a.get('engine')} (baseline {b.get('engine')}){looser}")
    if a.get("gl") != b.get("gl"):
        out.append(f"the GL renderer differs: {a.get('gl')} (baseline {b.get('gl')}){looser}")
    if a.get("iblcheck") != b.get("iblcheck"):
        out.append(f"iblcheck {a.get('iblcheck')} (baseline {b.get('iblcheck')})")
    sa, sb = record.get("settings") or {}, entry.get("settings") or {}
    diff = [f"{k} = {_short(sa.get(k, '(none)'))} (baseline {_short(sb.get(k, '(none)'))})"
            for k in sorted(set(sa) | set(sb)) if sa.get(k) != sb.get(k)]
    if diff:
        out.append("settings differ from the baseline's: " + ", ".join(diff))
    elif a.get("techniques") != b.get("techniques"):
        out.append("the techniques differ")
    return out


def _short(value: Any) -> str:
    text = json.dumps(value, default=str) if not isinstance(value, str) else value
    return text if len(text) <= 60 else text[:57] + "..."


def compare_record(record: dict, entry: dict, tolerances: dict) -> tuple[list[Delta], list[str], list[str]]:
    """(deltas, failures, warnings) of a run's record against its baseline record (module docstring)."""
    new, base = record["metrics"], entry["metrics"]
    same_ref = (record["identity"].get("reference_sha256") is not None
                and record["identity"].get("reference_sha256") == entry.get("identity", {}).get("reference_sha256"))
    deltas, failures = [], []
    for metric, unit, worse in BASELINE_METRICS:
        b, n = base.get(metric), new.get(metric)
        if b is None:
            deltas.append(Delta(metric, b, n, None))
            continue
        if n is None:
            deltas.append(Delta(metric, b, n, None, True))
            # an empty comparison now, a measured one in the baseline: a change even where allow_empty
            why = new.get("no_signal") or "no covered pixels"
            failures.append(f"{metric} undefined ({why}), baseline {b:.4g}")
            continue
        given = tolerances.get({"psnr": "tolerance_db"}.get(metric, f"tolerance_{metric}"))
        if given is not None:
            tol = given
        elif metric == "psnr":
            tol = psnr_tolerance_db(base, new, same_ref) if base.get("noise_floor_psnr") is not None \
                and new.get("noise_floor_psnr") is not None else 0.0
        else:
            tol = metric_tolerance(base.get(f"{metric}_se"), new.get(f"{metric}_se"),
                                   shift=0.0 if same_ref else noise_shift(metric, base, new))
        d = Delta(metric, b, n, tol, worsened_beyond(b, n, worse, tol))
        deltas.append(d)
        if d.failed:
            u = f" {unit}" if unit else ""
            verb = "fell" if worse < 0 else "rose"
            failures.append(f"{metric} {verb} from the baseline {_fmt(metric, b)} to {_fmt(metric, n)}{u} "
                            f"(delta {_fmt(metric, d.delta, True)}{u}; tolerance {_fmt(metric, tol)}{u})")
    tb = ((entry.get("timings") or {}).get("realtime_ms") or {}).get("total")
    tn = ((record.get("timings") or {}).get("realtime_ms") or {}).get("total")
    limit = tolerances.get("max_time_ratio")
    d = Delta("time", tb, tn, limit)
    ratio = d.delta
    if limit is not None and tb is not None and tn is not None and (ratio is None or ratio > limit):
        d.failed = True
        failures.append(f"frame time {tn:.2f} ms is {'inf' if ratio is None else f'{ratio:.2f}'}x the baseline "
                        f"{tb:.2f} ms, above --max-time-ratio {limit:g}")
    deltas.append(d)
    warnings = identity_differences(record, entry)
    if limit is not None and (tb is None or tn is None):  # a time limit asked for and no time to hold to it
        which = "this run" if tn is None else "the baseline"
        warnings.append(f"--max-time-ratio {limit:g} not checked: {which} has no frame time (an engine image without "
                        "a timings file?)")
    return deltas, failures, warnings


def _fmt(metric: str, value: float | None, signed: bool = False) -> str:
    if value is None:
        return "-"
    spec = {"psnr": ".2f", "time": ".2f"}.get(metric, ".4f")
    return format(value, ("+" if signed else "") + spec)


# --------------------------------------------------------------------------- the baseline file


def write_baseline(path: Path, results: list[GateResult]) -> None:
    """FILE: this run's records, keyed by scene key (written atomically)."""
    scenes_out = {}
    for r in results:
        if r.record is not None:
            scenes_out[record_key(r.record)] = r.record
    data = {"format": FORMAT, "version": VERSION, "iblcheck": iblcheck_version(),
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "scenes": scenes_out}
    write_text(path, json.dumps(data, indent=1, sort_keys=True, allow_nan=False) + "\n")


def record_key(record: dict) -> str:
    """A record's key in the baseline file: the scene as named, or SCENE#LABEL for an engine image."""
    return record.get("key") or scene_key(record["spec"])


class _Constant(str):
    """NaN, Infinity or -Infinity where the file holds one: parsed as a marker, so that the error can name
    the field (`_find_constant`) instead of only the file."""


def _find_constant(node, where: str = "") -> tuple[str, str] | None:
    """(field, constant) of the first _Constant in a parsed tree, fields as the checks name them:
    scenes[KEY].metrics.psnr."""
    if isinstance(node, _Constant):
        return where, str(node)
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, child in items:
        if where == "scenes" and isinstance(node, dict):
            sub = f"scenes[{key}]"
        elif isinstance(key, int):
            sub = f"{where}[{key}]"
        else:
            sub = f"{where}.{key}" if where else str(key)
        found = _find_constant(child, sub)
        if found:
            return found
    return None


def read_baseline(path: str | Path) -> dict:
    """The baseline file at `path`, checked: {"path", "scenes": {key: record}, ...}. Every problem is a
    BaselineError naming the file (and the field)."""
    path = Path(path)
    data = read_input(path, "baseline file", MAX_BASELINE_BYTES, BaselineError)
    try:
        tree = json.loads(data.decode("utf-8"), parse_constant=_Constant)
    except UnicodeDecodeError as exc:
        raise BaselineError(f"{path}: baseline file is not UTF-8 text (byte {exc.start})") from None
    except json.JSONDecodeError as exc:
        raise BaselineError(f"{path}: baseline file is not valid JSON (line {exc.lineno}, column {exc.colno}: "
                            f"{exc.msg})") from None
    except ValueError as exc:  # a number too long to convert
        raise BaselineError(f"{path}: baseline file {exc}") from None
    except RecursionError:
        raise BaselineError(f"{path}: baseline file nests too deep") from None
    try:
        constant = _find_constant(tree)
    except RecursionError:
        raise BaselineError(f"{path}: baseline file nests too deep") from None
    if constant:
        raise BaselineError(f"{path}: {constant[0] or 'the file'} = {constant[1]}, which is not a number JSON allows")
    if not isinstance(tree, dict) or tree.get("format") != FORMAT:
        raise BaselineError(f"{path}: not an iblcheck gate baseline (no \"format\": \"{FORMAT}\"); write one with "
                            "`iblcheck gate SCENES --write-baseline FILE`")
    version = tree.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or not 1 <= version <= VERSION:
        raise BaselineError(f"{path}: baseline format version {_short(version)}: this iblcheck reads version "
                            f"{VERSION}")
    scenes_in = tree.get("scenes")
    if not isinstance(scenes_in, dict):
        raise BaselineError(f"{path}: \"scenes\" must be an object of scene records")
    for key, entry in scenes_in.items():
        _check_entry(path, key, entry)
    return {**tree, "path": str(path)}


def _check_entry(path: Path, key: str, entry: Any) -> None:
    where = f"{path}: scenes[{_short(key)}]"
    if not isinstance(entry, dict):
        raise BaselineError(f"{where}: must be an object")
    metrics = entry.get("metrics")
    if not isinstance(metrics, dict):
        raise BaselineError(f"{where}.metrics: missing or not an object")
    # each number for its meaning (a standard error >= 0, a PSNR in [0, 100], ...): experiments/measure/fields.py
    fields.check(metrics, RECORD_NUMBERS, f"{where}.metrics", BaselineError)
    fields.check_pixels(metrics, f"{where}.metrics", BaselineError)
    if metrics.get("psnr") is not None and metrics.get("noise_floor_psnr") is None:
        raise BaselineError(f"{where}.metrics.noise_floor_psnr: null beside a PSNR (the rule needs both)")
    timings = entry.get("timings")
    rt = timings.get("realtime_ms") if isinstance(timings, dict) else None
    # an engine image's record has a frame time only when its engine wrote a timings file
    if not isinstance(rt, dict) or (rt.get("total") is None and not entry.get("image")):
        raise BaselineError(f"{where}.timings.realtime_ms.total: missing; a finite time >= 0 is required")
    fields.check_timings(rt, f"{where}.timings.realtime_ms", BaselineError)
    for k in ("identity", "settings"):
        if not isinstance(entry.get(k, {}), dict):
            raise BaselineError(f"{where}.{k}: must be an object")
    if not isinstance(entry.get("identity", {}).get("reference", {}), dict):
        raise BaselineError(f"{where}.identity.reference: must be an object")


# --------------------------------------------------------------------------- output


def format_table(results: list[GateResult]) -> str:
    lines = [f"{'scene':<22} {'result':<6} {'PSNR':>7} {'SSIM':>7} {'FLIP':>7}  checks"]
    for r in results:
        def f(key, spec, m=r.metrics):
            return "-" if m.get(key) is None else format(m[key], spec)

        checks = ", ".join(f"{k}={v:g}" for k, v in r.thresholds.items())
        if r.baseline:
            checks = ", ".join(x for x in (checks, f"baseline ({r.baseline})") if x)
        lines.append(f"{one_line(r.scene, 60):<22} {'PASS' if r.passed else 'FAIL':<6} {f('psnr', '.2f'):>7} "
                     f"{f('ssim', '.4f'):>7} "
                     f"{f('flip', '.4f'):>7}  {checks}")
        if r.deltas:
            lines.append(f"    {'':<8} {'baseline':>10} {'new':>10} {'delta':>10} {'tolerance':>10}")
            for d in r.deltas:
                label = {"psnr": "PSNR dB", "ssim": "SSIM", "flip": "FLIP", "time": "frame ms"}[d.metric]
                delta = "-" if d.delta is None else (f"x{d.delta:.2f}" if d.metric == "time"
                                                     else _fmt(d.metric, d.delta, True))
                tol = "-" if d.tolerance is None else (f"x{d.tolerance:g}" if d.metric == "time"
                                                       else _fmt(d.metric, d.tolerance))
                lines.append(f"    {label:<8} {_fmt(d.metric, d.baseline):>10} {_fmt(d.metric, d.new):>10} "
                             f"{delta:>10} {tol:>10}{'  FAIL' if d.failed else ''}")
        lines += [f"    - {one_line(msg)}" for msg in r.failures]
    n_fail = sum(not r.passed for r in results)
    lines.append(f"{len(results) - n_fail} passed, {n_fail} failed")
    return "\n".join(lines)


def warning_lines(results: list[GateResult], baseline: dict | None) -> list[str]:
    """The `warning:`/`note:` lines of a baseline comparison (identity differences, unused records)."""
    out = [f"warning: {one_line(r.scene, 60)}: {one_line(w)}" for r in results for w in r.warnings]
    if baseline is not None:
        used = {record_key(r.record) for r in results if r.record}
        unused = [k for k in baseline["scenes"] if k not in used]
        if unused:
            out.append(one_line(f"note: {len(unused)} scene(s) of the baseline {baseline['path']} were not gated: "
                                + ", ".join(unused)))
    return out


def write_junit(path: Path, results: list[GateResult]) -> None:
    suite = ET.Element("testsuite", name="iblcheck gate", tests=str(len(results)),
                       failures=str(sum(not r.passed for r in results)), errors="0",
                       time=f"{sum(r.seconds for r in results):.3f}")
    for r in results:
        case = ET.SubElement(suite, "testcase", classname="iblcheck.gate", name=xml_text(r.scene),
                             time=f"{r.seconds:.3f}")
        props = ET.SubElement(case, "properties")

        def prop(name: str, value, props=props) -> None:
            ET.SubElement(props, "property", name=name, value="null" if value is None else f"{value:.6g}")

        for k in ("psnr", "ssim", "flip", "noise_floor_psnr"):
            prop(k, r.metrics.get(k))
        if r.baseline:
            ET.SubElement(props, "property", name="baseline", value=r.baseline)
        for d in r.deltas:
            prefix = "frame_ms" if d.metric == "time" else d.metric
            prop(f"{prefix}.baseline", d.baseline)
            prop(f"{prefix}.new", d.new)
            prop(f"{prefix}.ratio" if d.metric == "time" else f"{prefix}.delta", d.delta)
            prop(f"{prefix}.max_ratio" if d.metric == "time" else f"{prefix}.tolerance", d.tolerance)
        if r.deltas or r.warnings:
            out = ET.SubElement(case, "system-out")
            out.text = "\n".join(xml_text(x) for x in _delta_lines(r) + [f"warning: {w}" for w in r.warnings])
        if r.failures:
            kind = "MissingBaseline" if r.baseline == "missing" else "ImageQuality"
            fail = ET.SubElement(case, "failure", message=xml_text("; ".join(r.failures)), type=kind)
            fail.text = "\n".join(xml_text(f) for f in r.failures)
    root = ET.Element("testsuites", name="iblcheck")
    root.append(suite)
    write_bytes(path, ET.tostring(root, encoding="utf-8", xml_declaration=True))


def _delta_lines(r: GateResult) -> list[str]:
    out = []
    for d in r.deltas:
        if d.metric == "time":
            ratio = "-" if d.delta is None else f"x{d.delta:.2f}"
            out.append(f"frame ms: baseline {_fmt('time', d.baseline)}, new {_fmt('time', d.new)}, ratio {ratio}"
                       + ("" if d.tolerance is None else f", max x{d.tolerance:g}") + (" FAIL" if d.failed else ""))
        else:
            out.append(f"{d.metric}: baseline {_fmt(d.metric, d.baseline)}, new {_fmt(d.metric, d.new)}, "
                       f"delta {_fmt(d.metric, d.delta, True)}, tolerance {_fmt(d.metric, d.tolerance)}"
                       + (" FAIL" if d.failed else ""))
    return out


def markdown(results: list[GateResult], baseline: dict | None = None) -> str:
    """A short Markdown summary for a pull-request comment: one row per scene, each metric as
    `baseline → new (delta)` when compared with a baseline; failures and warnings below."""
    n_fail = sum(not r.passed for r in results)
    head = f"### iblcheck gate: {n_fail} failed, {len(results) - n_fail} passed"
    if baseline is not None:
        head += f" against the baseline {md_cell(Path(baseline['path']).name)}"
    lines = [head, "", "| scene | result | PSNR dB | SSIM | FLIP | frame ms |", "|---|---|--:|--:|--:|--:|"]
    for r in results:
        by = {d.metric: d for d in r.deltas}
        cells = []
        for metric in ("psnr", "ssim", "flip", "time"):
            d = by.get(metric)
            value = r.metrics.get(metric) if metric != "time" else (r.metrics.get("realtime_ms") or {}).get("total")
            if d is None:
                cells.append(_fmt(metric, value))
                continue
            if metric == "time":
                change = "-" if d.delta is None else f"x{d.delta:.2f}"
            else:
                change = _fmt(metric, d.delta, True)
            mark = " **✗**" if d.failed else ""
            cells.append(f"{_fmt(metric, d.baseline)} → {_fmt(metric, d.new)} ({change}){mark}")
        status = "**FAIL**" if not r.passed else "pass"
        if r.baseline == "missing":
            status += " (not in baseline)"
        lines.append(f"| {md_cell(one_line(r.scene, 80))} | {status} | " + " | ".join(cells) + " |")
    notes = [f"- {md_cell(one_line(r.scene, 80))}: {md_cell(f)}" for r in results for f in r.failures]
    notes += [f"- warning: {md_cell(one_line(r.scene, 80))}: {md_cell(w)}" for r in results for w in r.warnings]
    if notes:
        lines += ["", *notes]
    return "\n".join(lines) + "\n"


def write_markdown(path: Path, results: list[GateResult], baseline: dict | None = None) -> None:
    write_text(path, markdown(results, baseline))
