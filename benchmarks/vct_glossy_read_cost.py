"""What voxel cone tracing's deferred glossy read costs a frame, against the six-face read, in one run.

    .venv/bin/python benchmarks/vct_glossy_read_cost.py [--scenes torus-phong,cornell-open] [--resolution 64]
                                                        [--pixels 128] [--frames 3] [--repeats 3]

Renders each scene with `occlusion = interreflection = "vct"` (one cascade) under `[realtime.vct] glossy_read =
"deferred"` and `"six_faces"`, alternating the two `--repeats` times so that a drift of the machine's load falls
on both, each render timing `--frames` frames after one warm-up; prints per scene and read the median over the
renders of each render's median `voxelize` (the injection and its mips' wait), `mip` and `draw` (the shading
pass, whose cones read the faces) in ms, and the ratios deferred / six faces. On llvmpipe these are CPU times.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

import realtime
import scenes

READS = ("deferred", "six_faces")
PARTS = ("voxelize", "mip", "draw")


def frame_parts(spec: str, read: str, resolution: int, pixels: int, frames: int) -> dict[str, float]:
    scene = scenes.load(spec).with_overrides({
        "camera.width": pixels, "camera.height": pixels, "realtime.occlusion": "vct",
        "realtime.interreflection": "vct", "realtime.vct.resolution": resolution, "realtime.vct.cascades": 1,
        "realtime.vct.glossy_read": read, "realtime.timing_frames": frames, "realtime.warmup_frames": 1})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the missing effects' warnings: not what is measured
        render = realtime.render(scene)
    return {k: float(render.timings[k]) for k in PARTS}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default="torus-phong,cornell-open")
    ap.add_argument("--resolution", type=int, default=64)
    ap.add_argument("--pixels", type=int, default=128)
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    for name in args.scenes.split(","):
        spec = f"builtin:{name}"
        runs: dict[str, list[dict[str, float]]] = {read: [] for read in READS}
        for _ in range(args.repeats):
            for read in READS:
                runs[read].append(frame_parts(spec, read, args.resolution, args.pixels, args.frames))
        med = {read: {k: float(np.median([r[k] for r in runs[read]])) for k in PARTS} for read in READS}
        cells = ", ".join(f"{k} {med['deferred'][k]:.0f} / {med['six_faces'][k]:.0f} ms "
                          f"({med['deferred'][k] / med['six_faces'][k]:.2f}x)" for k in PARTS)
        print(f"{name} {args.resolution}^3, {args.pixels}^2 px, deferred / six faces (llvmpipe: CPU times): {cells}")


if __name__ == "__main__":
    main()
