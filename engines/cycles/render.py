"""The Cycles bridge: an `iblcheck export` folder -> a linear float32 OpenEXR rendered by Blender's Cycles.

    python -m engines.cycles.render --sidecar FILE --output FILE.exr [--timings FILE.json]
                                    [--spp N] [--seed S] [--max-bounces B] [--threads T]

Run it with a Python that has bpy (Blender's module; its own environment, since bpy pins numpy < 2) and this
repository on PYTHONPATH. Exit codes: 0 after writing the image, 2 with one `error:` line when the export
cannot be rendered (a bad key, a material Cycles has no closure for), 3 with one line when bpy is missing.
The image is written atomically (a temporary file beside it, checked finite, then renamed), row 0 the top,
exactly the sidecar's width x height.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from engines.cycles import exported, materials, settings
from engines.cycles.errors import EngineMissing, SceneRejected

DEFAULT_SPP = 256


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m engines.cycles.render", description=__doc__.split("\n\n")[0])
    p.add_argument("--sidecar", required=True, type=Path, help="the export's iblcheck-export.json")
    p.add_argument("--output", required=True, type=Path, help="the OpenEXR image to write")
    p.add_argument("--timings", type=Path, help="a JSON file for the engine's timings")
    p.add_argument("--spp", type=int, default=None,
                   help=f"samples per pixel (default: the sidecar's reference.spp, else {DEFAULT_SPP})")
    p.add_argument("--seed", type=int, default=0, help="Cycles' seed (default 0)")
    p.add_argument("--max-bounces", type=int, default=None,
                   help="Cycles' max_bounces (default: the sidecar's reference.max_depth - 2)")
    p.add_argument("--threads", type=int, default=0, help="CPU threads (default 0: all)")
    return p


def import_bpy():
    """bpy, or EngineMissing saying what to install."""
    try:
        import bpy  # deferred: a 370 MB module that only this entry point needs, absent from iblcheck's own venv
    except ImportError as exc:
        raise EngineMissing(f"Blender's bpy cannot be imported by {sys.executable} ({exc}); `make setup` creates "
                            ".venv-cycles with bpy, run the bridge with .venv-cycles/bin/python") from None
    return bpy


def build_scene(bpy, export: exported.Export, spp: int, seed: int, max_bounces: int, threads: int = 0,
                view_transform: str = "Standard") -> list[materials.Choice]:
    """The whole Blender scene of `export` in a fresh, empty file; returns the material choices."""
    from engines.cycles import camera, meshes, world  # deferred: bpy builders, used only once bpy is loaded

    choices = [materials.choose(o.material, f"{export.sidecar}: objects[{i}].material")
               for i, o in enumerate(export.objects)]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    settings.configure(bpy, export.view, spp, seed, max_bounces, threads, view_transform)
    camera.build(bpy, export.view)
    world.build(bpy, export.environment, export.rotation_y_deg, export.intensity)
    for i, (obj, choice) in enumerate(zip(export.objects, choices, strict=True)):
        meshes.build(bpy, obj, f"object{i}", materials.build(bpy, choice, f"material{i}"))
    return choices


def read_exr(bpy, path: Path, width: int, height: int) -> np.ndarray:
    """The (H, W, 3) float32 image Blender wrote, row 0 the top (Blender's pixels are bottom row first)."""
    image = bpy.data.images.load(str(path), check_existing=False)
    try:
        if tuple(image.size) != (width, height):
            raise SceneRejected(f"{path}: Cycles wrote {tuple(image.size)} pixels, not {width} x {height}")
        pixels = np.empty(width * height * image.channels, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        rgb = pixels.reshape(height, width, image.channels)[::-1, :, :3]
    finally:
        bpy.data.images.remove(image)
    return np.ascontiguousarray(rgb)


def render(bpy, export: exported.Export, output: Path, spp: int, seed: int, max_bounces: int, threads: int = 0,
           view_transform: str = "Standard") -> dict:
    """Render `export` to `output` (atomically); returns the timings dict."""
    t0 = time.perf_counter()
    choices = build_scene(bpy, export, spp, seed, max_bounces, threads, view_transform)
    output = output.resolve()
    output.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{output.name}.tmp-", suffix=".exr", dir=output.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        bpy.context.scene.render.filepath = str(tmp)
        t1 = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        t2 = time.perf_counter()
        rgb = read_exr(bpy, tmp, export.view.width, export.view.height)
        bad = ~np.isfinite(rgb)
        if bad.any():
            r, c, _ = np.argwhere(bad)[0]
            raise SceneRejected(f"{export.sidecar}: Cycles' image has {int(bad.sum())} NaN/Inf values (first at "
                                f"row {r}, column {c})")
        os.replace(tmp, output)
    finally:
        tmp.unlink(missing_ok=True)
    nearest = [f"objects[{i}] {c.closure}" for i, c in enumerate(choices) if not c.exact]
    return {"engine": "Cycles", "version": bpy.app.version_string, "frame_ms": [(t2 - t1) * 1e3],
            "precompute_ms": (t1 - t0) * 1e3, "render_s": t2 - t1, "spp": spp, "seed": seed,
            "max_bounces": max_bounces,
            "notes": ("all materials exact" if not nearest else
                      f"nearest, not exact: {', '.join(nearest)}: {materials.PRINCIPLED_DIFFERENCE}")}


def write_json(path: Path, data: dict) -> None:
    """`data` as JSON, atomically (a temporary file beside `path`, renamed onto it)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.tmp-", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=1, allow_nan=False)
        os.replace(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        if args.spp is not None and args.spp < 1:
            raise SceneRejected(f"--spp = {args.spp} is not a positive number of samples")
        if args.max_bounces is not None and args.max_bounces < 0:
            raise SceneRejected(f"--max-bounces = {args.max_bounces} is negative")
        bpy = import_bpy()
        export = exported.read(args.sidecar)
        bounces = settings.bounces(export.max_depth) if args.max_bounces is None else args.max_bounces
        spp = args.spp or export.spp or DEFAULT_SPP
        timings = render(bpy, export, args.output, spp, args.seed, bounces, args.threads)
        if args.timings:
            write_json(args.timings, timings)
    except (SceneRejected, EngineMissing) as exc:
        print(f"error: {' '.join(str(exc).split())}", file=sys.stderr)
        return exc.exit_code
    return 0


if __name__ == "__main__":
    sys.exit(main())
