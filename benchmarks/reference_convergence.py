"""Mitsuba reference cost on this machine: time to a noise floor, and the plugin's overhead.

    .venv/bin/python benchmarks/reference_convergence.py [--size 256] [--repeats 3] [--json out.json]

1. For sphere-diffuse and sphere-blend at SIZE x SIZE: spp in 64 ... 4096, the noise floor
   (docs/contract.md section 7, experiments.measure.metrics.noise_floor_psnr) and the median render time; the
   first spp whose floor reaches 45 dB is the "time to a 45 dB reference".
2. The paper plugin against Mitsuba's built-in `diffuse` on sphere-diffuse at equal spp (the
   same scene with reference.model = "physical"): median render times and their ratio, measured
   alternately in one run.
Caching is off: every number is a fresh render (kernel compilation included in the first one,
excluded from the medians by a warm-up render).
"""

from __future__ import annotations

import argparse
import json

import numpy as np

import scenes
from experiments.measure import metrics
from groundtruth.pathtracer.reference import render, second_seed

TARGET_DB = 45.0


def convergence(name: str, size: int, spps: list[int], repeats: int) -> list[dict]:
    scene = scenes.load(f"builtin:{name}").with_overrides({"camera.width": size, "camera.height": size})
    render(scene, spp=16, use_cache=False)  # warm-up: compile the kernels
    rows = []
    for spp in spps:
        times, pair = [], None
        for k in range(max(2, repeats)):
            r = render(scene, spp=spp, seed=k if k else 0, use_cache=False)
            times.append(r.timings["render"] / 1e3)
            if k == 0:
                pair = [r]
        pair.append(render(scene, spp=spp, seed=second_seed(0), use_cache=False))
        mask = metrics.common_mask(pair[0].mask, pair[1].mask)
        floor = metrics.noise_floor_psnr(metrics.display(scene, pair[0].rgb), metrics.display(scene, pair[1].rgb),
                                         mask)
        rows.append({"scene": name, "size": size, "spp": spp, "noise_floor_psnr": floor,
                     "render_s": float(np.median(times))})
        print(json.dumps(rows[-1]), flush=True)
        if floor is not None and floor >= TARGET_DB + 3:
            break
    return rows


def plugin_overhead(size: int, spp: int, repeats: int) -> dict:
    base = scenes.load("builtin:sphere-diffuse").with_overrides({"camera.width": size, "camera.height": size})
    variants = {"paper": base, "builtin": base.with_overrides({"reference.model": "physical"})}
    for s in variants.values():
        render(s, spp=16, use_cache=False)
    times = {k: [] for k in variants}
    for _ in range(repeats):
        for k, s in variants.items():
            times[k].append(render(s, spp=spp, use_cache=False).timings["render"] / 1e3)
    out = {k: float(np.median(v)) for k, v in times.items()}
    out.update(spp=spp, size=size, ratio=out["paper"] / out["builtin"])
    print(json.dumps({"plugin_overhead": out}), flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json")
    args = ap.parse_args()
    spps = [64, 256, 1024, 1280, 4096]
    rows = convergence("sphere-diffuse", args.size, spps, args.repeats)
    rows += convergence("sphere-blend", args.size, spps, args.repeats)
    summary = {}
    for name in ("sphere-diffuse", "sphere-blend"):
        ok = [r for r in rows if r["scene"] == name and (r["noise_floor_psnr"] or 0) >= TARGET_DB]
        summary[name] = ok[0] if ok else None
    overhead = plugin_overhead(args.size, 256, args.repeats)
    result = {"rows": rows, "time_to_45db": summary, "plugin_overhead": overhead}
    print(json.dumps({"time_to_45db": summary}))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
