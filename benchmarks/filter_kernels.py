"""Per-run times of the two accuracy-ladder filters on this machine (docs/contract.md section 7: medians
of wall time around the work with ctx.finish(), warm-up excluded).

    .venv/bin/python benchmarks/filter_kernels.py [--runs 20] [--json out.json]

- irradiance map (realtime/techniques/irradiance_map/irradiance_convolution.py): output face 16/32/64 from source
face 16/32;
- Phong prefilter (realtime/techniques/prefiltered/prefilter.py): base 256, levels from face 64 down (first_level 2),
  exponents 10/100/1000, 16 ... 1024 samples, FIS on (bias 0).
Also printed: CPU time of the process (llvmpipe's threads included), which is less disturbed than
wall time when other jobs share the cores.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from realtime.engine.context import get_context, renderer_name
from realtime.engine.gpu import EnvironmentFilter
from realtime.techniques.irradiance_map.irradiance_convolution import IrradianceConvolver
from realtime.techniques.prefiltered.prefilter import PhongPrefilter
from scenes.environment import environments


def measure(ctx, work, runs: int, warmup: int = 3) -> dict[str, float]:
    for _ in range(warmup):
        work()
    ctx.finish()
    wall, cpu = [], []
    for _ in range(runs):
        ctx.finish()
        t0, c0 = time.perf_counter(), time.process_time()
        work()
        ctx.finish()
        wall.append((time.perf_counter() - t0) * 1e3)
        cpu.append((time.process_time() - c0) * 1e3)
    return {"ms": float(np.median(wall)), "ms_min": float(np.min(wall)), "cpu_ms": float(np.median(cpu))}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--prefilter-runs", type=int, default=10)
    ap.add_argument("--json")
    args = ap.parse_args()
    ctx = get_context()
    out: dict = {"gl": renderer_name(), "irradiance_map": [], "prefilter": []}
    env = environments.builtin("uffizi")

    env_filter = EnvironmentFilter(ctx, env, 256)
    env_filter.fill_base(0.0)
    env_filter.build_chain()
    for source in (16, 32):
        for size in (16, 32, 64):
            conv = IrradianceConvolver(ctx, size, source)
            level = int(np.log2(256 // source))
            timing = measure(ctx, lambda c=conv, lv=level: c.run(env_filter.cube, lv), args.runs)
            row = {"size": size, "source_size": source, **timing}
            conv.release()
            out["irradiance_map"].append(row)
            print(f"irradiance_map size {size:3d} source {source:3d}: {row['ms']:7.1f} ms  (cpu {row['cpu_ms']:.1f})",
                  flush=True)

    for exponent in (10.0, 100.0, 1000.0):
        for samples in (16, 64, 256, 1024):
            pre = PhongPrefilter(ctx, 256, exponent, samples, 0.0)
            row = {"exponent": exponent, "samples": samples, "first_level": 2,
                   **measure(ctx, lambda p=pre: p.run(env_filter.cube, 2), args.prefilter_runs, warmup=1)}
            pre.release()
            out["prefilter"].append(row)
            print(f"prefilter N {exponent:6.0f} samples {samples:4d}: {row['ms']:7.1f} ms  (cpu {row['cpu_ms']:.1f})",
                  flush=True)
    env_filter.release()
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
