"""`iblcheck gate --images MANIFEST` and `iblcheck sweep --images MANIFEST`: engine images listed in a
manifest (experiments/runs/image_manifest.py), gated or appended as result rows."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from experiments.cli.inputs import UsageError, gate_options, gate_outputs_are_no_inputs, parse_sets
from experiments.measure.results import RESULTS, folder_lock, store_in
from experiments.publish import outputs
from experiments.publish.report import build as build_report
from experiments.publish.text import one_line
from experiments.runs import gate, image_manifest
from experiments.runs.rows import image_row_id


def _manifest(args: argparse.Namespace, command: str) -> str:
    if not args.images:
        raise UsageError(f"iblcheck {command}: name at least one scene, or --images MANIFEST")
    if args.scenes:
        raise UsageError(f"iblcheck {command} --images {args.images}: the manifest names the scenes; give no "
                         f"scene arguments ({', '.join(args.scenes)})")
    return args.images


def gate_images(args: argparse.Namespace) -> int:
    """The gate over a manifest's images: thresholds, baseline, JUnit and Markdown as `iblcheck gate`."""
    manifest = _manifest(args, "gate")
    cli, tolerances = gate_options(args)
    with outputs.Outputs() as plan:
        baseline = gate.read_baseline(args.baseline) if args.baseline else None
        loaded = image_manifest.gate_plan(manifest, cli, parse_sets(args.set),
                                          thresholds_required=not (args.baseline or args.write_baseline))
        junit = plan.file(args.junit, "--junit") if args.junit else None
        md = plan.file(args.markdown, "--markdown") if args.markdown else None
        record = plan.file(args.write_baseline, "--write-baseline") if args.write_baseline else None
        gate_outputs_are_no_inputs(args, loaded, junit, md, record, manifest)
        with outputs.progress("gate", 4 * len(loaded)) as step:
            results = gate.compare_all(loaded, baseline, tolerances, step, noise=bool(args.write_baseline))
        for line in gate.warning_lines(results, baseline):
            print(line, file=sys.stderr)
        print(gate.format_table(results))
        for p in loaded:
            if p.image.display_space:
                print(one_line(f"{p.key}: {p.image.path.name}: display-space metrics only (the image is "
                               f"tone-mapped sRGB, {p.image.tonemap})"))
        if junit:
            gate.write_junit(junit, results)
        if md:
            gate.write_markdown(md, results, baseline)
        if record:
            gate.write_baseline(record, results)
    return 0 if all(r.passed for r in results) else 1


def sweep_images(args: argparse.Namespace) -> int:
    """One result row per manifest entry appended to OUT/results.jsonl (rows already there are kept)."""
    manifest = _manifest(args, "sweep")
    sweep_only = {"--face-sizes": args.face_sizes, "--lod-biases": args.lod_biases, "--exponents": args.exponents,
                  "--f0s": args.f0s, "--envs": args.envs, "--lod-mappings": args.lod_mappings, "--axis": args.axis,
                  "--technique-axes": args.technique_axes, "--workers": args.workers, "--scheduler": args.scheduler}
    given = [flag for flag, value in sweep_only.items() if value]
    if given:
        raise UsageError(f"{', '.join(given)}: not with --images (an engine's image is one configuration; sweep the "
                         "engine's own settings and list each image in the manifest)")
    out_dir = Path(args.out)
    loaded = image_manifest.load_images(manifest, parse_sets(args.set))
    with outputs.Outputs() as plan, folder_lock(plan.folder(out_dir, "--out")):
        store = store_in(out_dir)
        done = {r.id for r in store.read()}
        added = 0
        for entry, scene, image in loaded:
            rid = image_row_id(scene, image.path, image.encoding, image.tonemap, image.exposure, entry.label)
            if rid in done:
                continue
            store.append(image_manifest.image_row(out_dir, entry, scene, image))
            done.add(rid)
            added += 1
        build_report(out_dir)
    print(one_line(f"{added} image rows added ({len(loaded) - added} already there) in {out_dir / RESULTS}; "
                   f"report: {out_dir / 'index.html'}"))
    return 0

