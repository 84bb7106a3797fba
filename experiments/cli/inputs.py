"""Command-line inputs shared by the `iblcheck` subcommands: usage errors, `--set`, lists, scenes."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from experiments.measure.engine_image import timings_path
from experiments.publish.outputs import (
    UsageError,  # defined below the CLI: the output checks raise it
    same_file,
)
from scenes.exchange import scene_spec
from scenes.geometry.meshes import BUILTIN_MESHES
from scenes.model.scene import parse_literal


def parse_sets(items: list[str] | None) -> dict[str, str]:
    """`--set K=V` pairs -> {K: V}; values are parsed as TOML literals by Scene.with_overrides."""
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise UsageError(f"--set {item!r}: expected KEY=VALUE, e.g. --set realtime.lod_bias=2")
        out[key.strip()] = value.strip()
    return out


def load_scene(spec: str, sets: list[str] | None = None, sanitize: bool = False):
    """A scene file, builtin:NAME or a glTF Render Fidelity scenario (.json), with `--set` overrides."""
    scene = scene_spec.load(spec)
    overrides = parse_sets(sets)
    if sanitize:
        overrides["environment.sanitize"] = True
    return scene.with_overrides(overrides) if overrides else scene


def parse_axis(item: str) -> tuple[str, list[Any]]:
    """`--axis KEY=V1,V2,...` -> (KEY, [V1, V2, ...]); values are TOML literals (2, 0.5, "box" or box,
    [0, 0, 4]: commas inside brackets do not split)."""
    key, sep, values = item.partition("=")
    key = key.strip()
    if not sep or not key or not values.strip():
        raise UsageError(f"--axis {item!r}: expected KEY=V1,V2,..., e.g. --axis realtime.glossy=box,prefiltered")
    out = [parse_literal(v.strip()) for v in split_top_level(values) if v.strip()]
    return key, out


def split_top_level(text: str) -> list[str]:
    """Split at commas outside brackets and quotes: '[0,0,4],[0,0,6]' -> ['[0,0,4]', '[0,0,6]']."""
    parts, depth, quote, start = [], 0, "", 0
    for i, ch in enumerate(text):
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


def parse_list(text: str | None, kind: type, flag: str) -> list | None:
    """'8,16,32' -> [8, 16, 32]; None stays None; an empty list is refused (an empty axis is no sweep)."""
    if text is None:
        return None
    try:
        values = [kind(x.strip()) for x in text.split(",") if x.strip()]
    except ValueError:
        raise UsageError(f"{flag} {text!r}: expected a comma-separated list of {kind.__name__} values") from None
    if not values:
        raise UsageError(f"{flag} {text!r}: expected at least one {kind.__name__} value")
    return values


def gate_options(args) -> tuple[dict, dict]:
    """(thresholds, baseline tolerances) of `iblcheck gate`'s options, for scenes and for a manifest's images
    alike; a tolerance without --baseline is a UsageError."""
    cli = {"min_psnr": args.min_psnr, "min_ssim": args.min_ssim, "max_flip": args.max_flip}
    tolerances = {"tolerance_db": args.tolerance_db, "tolerance_ssim": args.tolerance_ssim,
                  "tolerance_flip": args.tolerance_flip, "max_time_ratio": args.max_time_ratio}
    given = [f"--{k.replace('_', '-')}" for k, v in tolerances.items() if v is not None]
    if given and not args.baseline:
        raise UsageError(f"{', '.join(given)}: only with --baseline FILE")
    return cli, tolerances


def scene_inputs(scene) -> list[str]:
    """The files a scene reads (its own file, its environment map, its mesh files): no output may overwrite
    them."""
    files = [] if scene.path.startswith("builtin:") else [scene.path]
    if not scene.environment.builtin_name:
        files.append(scene.environment.map)
    return files + [o.shape for o in scene.objects if o.shape not in BUILTIN_MESHES]


def refuse_overwriting(outputs: Iterable[tuple[Path | None, str]], inputs: Iterable[str | Path]) -> None:
    """UsageError when an output (path, flag) is one of the command's input files or another output: checked
    before any work, so that a mistyped `--junit scene.toml` never replaces the scene."""
    inputs = list(inputs)
    seen: list[tuple[Path, str]] = []
    for path, flag in outputs:
        if path is None:
            continue
        for source in inputs:
            if same_file(path, source):
                raise UsageError(f"{flag} {path}: would overwrite {source}, an input of this command")
        for other, other_flag in seen:
            if path.resolve() == other.resolve():
                raise UsageError(f"{flag} {path}: the same file as {other_flag}; give each output its own file")
        seen.append((path, flag))


def gate_outputs_are_no_inputs(args, loaded: list, junit, md, record,
                               manifest: str | None = None) -> None:
    """The gate's files (--junit, --markdown, --write-baseline) overwrite none of its inputs: the scenes'
    files, maps and meshes, an engine image and its timings file, the manifest, and (except for
    --write-baseline, which may update it) the baseline read."""
    inputs = [f for p in loaded for f in scene_inputs(p.scene)]
    images = [Path(p.image.path) for p in loaded if p.image is not None]
    inputs += images + [timings_path(i) for i in images]
    inputs += [manifest] if manifest else []
    baseline = [args.baseline] if args.baseline else []
    refuse_overwriting([(junit, "--junit"), (md, "--markdown")], inputs + baseline)
    refuse_overwriting([(record, "--write-baseline")], inputs)
    refuse_overwriting([(junit, "--junit"), (md, "--markdown"), (record, "--write-baseline")], [])
