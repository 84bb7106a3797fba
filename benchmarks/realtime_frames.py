"""Real-time frame times on this machine (docs/contract.md section 7: medians, warm-up excluded).

    .venv/bin/python benchmarks/realtime_frames.py [--frames 50] [--json out.json]

Reports: `draw` for a 512x512 blend sphere; `filter` (cube fill + box chain + SH9) for base 256
with the level at 64; and filter split into its parts for face sizes 8 ... 256, so the SH cost can
be read against the 6 s^2 texels it projects.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

import realtime
import scenes
from realtime.engine.context import get_context, renderer_name
from realtime.engine.gpu import EnvironmentFilter
from realtime.engine.timing import timed


def median_ms(ctx, work, frames: int, warmup: int = 5) -> float:
    for _ in range(warmup):
        timed(ctx, work)
    return float(np.median([timed(ctx, work) for _ in range(frames)]))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=50)
    ap.add_argument("--json")
    args = ap.parse_args()
    ctx = get_context()
    out: dict = {"gl": renderer_name(), "frames": args.frames}

    scene = scenes.load("builtin:sphere-blend").with_overrides({
        "camera.width": 512, "camera.height": 512, "realtime.timing_frames": args.frames,
        "realtime.warmup_frames": 5, "realtime.face_size": 64, "realtime.base_size": 256})
    r = realtime.render(scene)
    out["blend_512"] = r.timings
    print(f"{out['gl']}")
    print(f"blend sphere 512x512, base 256, level 64: draw {r.timings['draw']:.2f} ms (p90 "
          f"{r.timings['draw_p90']:.2f}), filter {r.timings['filter']:.2f} ms, total {r.timings['total']:.2f} ms")

    env = scenes.load("builtin:sphere-blend").environment.radiance()
    f = EnvironmentFilter(ctx, env, 256)
    rows = []
    print(f"{'face':>5} {'fill':>8} {'chain':>8} {'sh':>8} {'filter':>8}   (ms, medians of {args.frames})")
    for s in (8, 16, 32, 64, 128, 256):
        fill = median_ms(ctx, lambda: f.fill_base(10.0), args.frames)
        chain = median_ms(ctx, f.build_chain, args.frames)
        shp = median_ms(ctx, lambda s=s: f.project_sh(s), args.frames)
        full = median_ms(ctx, lambda s=s: (f.fill_base(10.0), f.build_chain(), f.project_sh(s)), args.frames)
        rows.append({"face_size": s, "texels": 6 * s * s, "fill": fill, "chain": chain, "sh": shp, "filter": full})
        print(f"{s:>5} {fill:>8.2f} {chain:>8.2f} {shp:>8.2f} {full:>8.2f}")
    f.release()
    out["filter_by_face_size"] = rows
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
