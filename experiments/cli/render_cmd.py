"""`iblcheck render`: one scene, one renderer -> OUT.exr (RGBA float32) + OUT.png + a JSON line.

Without `-o`, OUT is `<slug of the scene name>-<renderer>.exr` in the working directory (a slug
keeps letters, digits, '.', '_' and '-': a scene named "../../x" writes ./x-realtime.exr). Both
output files are checked before the render (experiments/publish/outputs.py) and written atomically; an
output that is the scene file, its map or a mesh of it is refused. While it renders, a progress line
with the elapsed time is shown on stderr when that is a terminal (outputs.progress).
"""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

import numpy as np

import groundtruth
import realtime
from engines import command as engine_command
from experiments.cli.inputs import UsageError, load_scene, refuse_overwriting, scene_inputs
from experiments.measure import metrics
from experiments.publish import images, outputs
from groundtruth.exact import quadrature
from scenes.model.render import Render
from scenes.storage import imageio


def render_with(renderer: str, scene) -> Render:
    if renderer == "realtime":  # iblcheck's OpenGL renderer, or the scene's external engine (realtime.renderer)
        return engine_command.render(scene) if scene.realtime.renderer == "command" else realtime.render(scene)
    if renderer == "reference":
        return groundtruth.render(scene)
    if renderer == "quadrature":
        if why := quadrature.inexact_for(scene):
            warnings.warn(why, quadrature.NotTheReference, stacklevel=2)
        return quadrature.render(scene)
    raise UsageError(f"--renderer {renderer!r}: choose realtime, reference or quadrature")


def write_outputs(out: Path, scene, result: Render) -> None:
    """OUT.exr with R, G, B, A (A = coverage mask) and OUT.png, tone-mapped like the metrics."""
    imageio.write_exr(out, result.rgb, alpha=result.mask.astype(np.float32))
    images.save_png(out.with_suffix(".png"), metrics.display(scene, result.rgb))


def default_out(scene, renderer: str) -> Path:
    """OUT when -o is not given: the scene name's slug, in the working directory."""
    return Path(f"{outputs.slug(scene.name)}-{renderer}.exr")


def check_out(plan: outputs.Outputs, out: Path, scene) -> None:
    if out.suffix.lower() != ".exr":
        raise UsageError(f"-o {out}: the output must be an .exr file")
    for path in (out, out.with_suffix(".png")):
        plan.file(path, "-o")
    refuse_overwriting([(out, "-o"), (out.with_suffix(".png"), "-o")], scene_inputs(scene))


def run(args: argparse.Namespace) -> int:
    scene = load_scene(args.scene, args.set, args.sanitize)
    out = outputs.file_path(args.out, "-o") if args.out else default_out(scene, args.renderer)
    with outputs.Outputs() as plan:
        check_out(plan, out, scene)
        with outputs.progress("render", 1) as step:
            step(f"{args.renderer}: {scene.name}")
            result = render_with(args.renderer, scene)
        write_outputs(out, scene, result)
    shown = ("variant", "spp", "seed", "integrator", "model", "face_size", "cache", "techniques",
             "unsimulated_effects")
    extra = {k: v for k, v in result.meta.items() if k in shown}
    print(json.dumps({"scene": scene.name, "renderer": args.renderer, "out": str(out),
                      "timings_ms": result.timings, **extra}))
    return 0
