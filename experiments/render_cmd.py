"""`iblcheck render`: one scene, one renderer -> OUT.exr (RGBA float32) + OUT.png + a JSON line."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from scenes import imageio
from scenes.render import Render

from . import images, metrics
from .inputs import UsageError, load_scene


def render_with(renderer: str, scene) -> Render:
    if renderer == "realtime":
        import realtime

        return realtime.render(scene)
    if renderer == "reference":
        import groundtruth

        return groundtruth.render(scene)
    if renderer == "quadrature":
        from groundtruth import quadrature

        return quadrature.render(scene)
    raise UsageError(f"--renderer {renderer!r}: choose realtime, reference or quadrature")


def write_outputs(out: Path, scene, result: Render) -> None:
    """OUT.exr with R, G, B, A (A = coverage mask) and OUT.png, tone-mapped like the metrics."""
    out.parent.mkdir(parents=True, exist_ok=True)
    imageio.write_exr(out, result.rgb, alpha=result.mask.astype(np.float32))
    images.save_png(out.with_suffix(".png"), metrics.display(scene, result.rgb))


def run(args: argparse.Namespace) -> int:
    scene = load_scene(args.scene, args.set, args.sanitize)
    out = Path(args.out or f"{scene.name}-{args.renderer}.exr")
    if out.suffix.lower() != ".exr":
        raise UsageError(f"-o {out}: the output must be an .exr file")
    result = render_with(args.renderer, scene)
    write_outputs(out, scene, result)
    shown = ("variant", "spp", "seed", "integrator", "model", "face_size", "cache", "techniques",
             "unsimulated_effects")
    extra = {k: v for k, v in result.meta.items() if k in shown}
    print(json.dumps({"scene": scene.name, "renderer": args.renderer, "out": str(out),
                      "timings_ms": result.timings, **extra}))
    return 0
