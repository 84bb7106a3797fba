"""`iblcheck export SCENE DIR`: the scene as glTF 2.0 + environment.hdr (viewer convention) + a JSON sidecar
(scenes/exchange/export.py), for rendering in another engine; `--fidelity-scenario` adds a glTF Render
Fidelity scenario.json. A phong or blend material is refused (exit 2) unless `--nearest`, which exports
the nearest GGX material with a `warning:` line and the difference in the sidecar."""

from __future__ import annotations

import argparse
import json
import time
import warnings

from experiments.cli.inputs import load_scene
from experiments.runs.rows import content_id
from scenes.exchange.export import export_scene


class ExportWarning(UserWarning):
    """A material exported as its nearest glTF equivalent."""


def add_parser(sub) -> None:
    e = sub.add_parser("export", help="write the scene as glTF 2.0 + environment.hdr + a JSON sidecar into DIR")
    e.add_argument("scene", help="scene file, builtin:NAME or a Render Fidelity scenario .json")
    e.add_argument("dir", help="output folder (new, empty, or an earlier export, which is replaced)")
    e.add_argument("--nearest", action="store_true",
                   help="export phong/blend materials as the nearest glTF material (stated in the sidecar)")
    e.add_argument("--fidelity-scenario", action="store_true",
                   help="also write scenario.json for glTF Render Fidelity harnesses (model-viewer's)")
    e.add_argument("--set", action="append", metavar="K=V", help="override a scene key (repeatable)")
    e.add_argument("--sanitize", action="store_true", help="replace NaN/Inf/negative environment pixels by 0")


def run(args: argparse.Namespace) -> int:
    scene = load_scene(args.scene, args.set, args.sanitize)
    start = time.perf_counter()
    out = export_scene(scene, args.dir, nearest=args.nearest, fidelity_scenario=args.fidelity_scenario,
                       content_id=content_id(scene))
    seconds = time.perf_counter() - start
    for line in out.warnings:
        warnings.warn(line, ExportWarning, stacklevel=2)
    files = [p for p in (out.gltf, out.gltf.with_suffix(".bin"), out.environment, out.sidecar, out.scenario) if p]
    print(json.dumps({"scene": scene.name, "folder": str(out.folder), "files": [p.name for p in files],
                      "bytes": sum(p.stat().st_size for p in out.folder.iterdir()), "seconds": round(seconds, 4)}))
    return 0
