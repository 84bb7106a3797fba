"""A 16-configuration reference sweep, serial against a local Dask cluster (`--workers N`).

    .venv/bin/python benchmarks/dask_sweep.py [--size 48] [--spp 64 1024] [--workers 2] [--repeats 1] [--json out.json]

The sweep: builtin:sphere-blend with 4 Phong exponents x 4 Fresnel f0 = 16 configurations, each with
its own reference (32 Mitsuba renders with the noise-floor seed), face size 32, LOD bias 0, 2 timed
frames. For each spp:

1. `sweep` (what a user waits for): `experiments.runs.sweep.run` serial, then with `workers` (cluster start
   included), each into a fresh reference cache; wall seconds, and for the Dask run its phases
   (`references`: submit to the last reference task; `rows`: the whole run, the driver's real-time
   part included) and the cluster's own start time.
2. `references` alone: the 32 renders in this process one after the other, against the same 32 as
   tasks on the cluster (started beforehand): the part Dask parallelises.
3. The workers' set-up (WorkerSetup: Mitsuba variant, libLLVM) against the mean task time.
4. Dask's own cost per task: 1000 tasks that do nothing, submitted with distinct keys and gathered
   (scheduler, transfer and worker round trip per task, on this machine's cores).

Dr.Jit's kernel cache (~/.drjit) is warm for both (one warm-up render first): compilation is not
measured. The machine's load (`uptime`) is printed before and after: other people share these cores.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import tempfile
import time
from pathlib import Path

EXPONENTS = [10.0, 50.0, 200.0, 1000.0]
F0S = [0.02, 0.04, 0.5, 1.0]
SPEC = "builtin:sphere-blend"


def sets(size: int, spp: int) -> dict:
    return {"camera.width": size, "camera.height": size, "reference.spp": spp, "realtime.timing_frames": 2,
            "realtime.warmup_frames": 1}


def uptime() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def axes():
    from experiments.runs import sweep

    return sweep.Axes(face_sizes=[32], lod_biases=[0.0], exponents=EXPONENTS, f0s=F0S)


def sweep_serial(size: int, spp: int, tmp: Path) -> dict:
    from experiments.runs import sweep

    os.environ["IBLCHECK_CACHE"] = str(tmp / "cache-serial")
    t0 = time.perf_counter()
    rows = sweep.run([SPEC], axes(), tmp / "serial", sets=sets(size, spp), report=False)
    wall = time.perf_counter() - t0
    return {"rows": len(rows), "wall_s": wall, "reference_s_sum": sum(r.reference_s or 0 for r in rows)}


def sweep_dask(size: int, spp: int, workers: int, tmp: Path) -> dict:
    from experiments.runs import sweep
    from experiments.runs.dask_cluster import Cluster

    os.environ["IBLCHECK_CACHE"] = str(tmp / "cache-dask")
    t0 = time.perf_counter()
    with Cluster(workers=workers, echo=None) as c:
        start_s = time.perf_counter() - t0
        rows = sweep.run([SPEC], axes(), tmp / "dask", sets=sets(size, spp), report=False, cluster=c)
        stats = c.stats
        setup = [i["setup_s"] for i in c.setup.values()]
    wall = time.perf_counter() - t0
    return {"rows": len(rows), "wall_s": wall, "cluster_start_s": start_s, "phases_s": stats.phases,
            "tasks": stats.done, "retried": len(stats.retried), "failed": stats.failed,
            "mean_task_s": sum(stats.seconds) / max(len(stats.seconds), 1), "task_s_sum": sum(stats.seconds),
            "worker_setup_s": setup}


def references_only(size: int, spp: int, workers: int, tmp: Path) -> dict:
    """The 32 renders serially here, then as tasks on a started cluster (no cache hits: fresh folders)."""
    from distributed import wait

    import scenes
    from experiments.runs.dask_cluster import Cluster
    from groundtruth.pathtracer.reference import render, second_seed

    scenes_ = [scenes.load(SPEC).with_overrides({**sets(size, spp), "objects.*.material.exponent": n,
                                                 "objects.*.material.f0": f0}) for n in EXPONENTS for f0 in F0S]
    os.environ["IBLCHECK_CACHE"] = str(tmp / "cache-ref-serial")
    t0 = time.perf_counter()
    for sc in scenes_:
        for seed in (0, second_seed(0)):
            render(sc, seed=seed)
    serial = time.perf_counter() - t0
    os.environ["IBLCHECK_CACHE"] = str(tmp / "cache-ref-dask")
    with Cluster(workers=workers, echo=None) as c:
        t0 = time.perf_counter()
        keys = [k for sc in scenes_ for k in c.submit_references(sc)]
        wait([c.futures[k] for k in keys])
        results = c.client.gather([c.futures[k] for k in keys])
        dask_s = time.perf_counter() - t0
        setup = [i["setup_s"] for i in c.setup.values()]
    task = [r["seconds"] for r in results]
    return {"renders": len(keys), "serial_s": serial, "dask_s": dask_s, "speedup": serial / dask_s,
            "mean_task_s": sum(task) / len(task), "task_s_sum": sum(task), "worker_setup_s": setup,
            "setup_fraction_of_task_time": sum(setup) / sum(task)}


def _noop(i: int) -> int:
    return i


def overhead_per_task(workers: int, n: int = 1000) -> dict:
    from experiments.runs.dask_cluster import Cluster

    with Cluster(workers=workers, echo=None) as c:
        c.client.gather(c.client.map(_noop, range(20), key=[f"warm-{i}" for i in range(20)]))
        t0 = time.perf_counter()
        futures = [c.client.submit(_noop, i, key=f"noop-{i}", pure=False) for i in range(n)]
        c.client.gather(futures)
        total = time.perf_counter() - t0
    return {"tasks": n, "seconds": total, "ms_per_task": 1e3 * total / n}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=48)
    ap.add_argument("--spp", type=int, nargs="+", default=[64, 1024])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()

    import scenes
    from groundtruth.pathtracer.reference import render

    render(scenes.load(SPEC).with_overrides(sets(args.size, 16)), use_cache=False)  # warm Dr.Jit's kernel cache
    out = {"uptime_before": uptime(), "cores": os.cpu_count(), "workers": args.workers, "size": args.size, "runs": []}
    print(out["uptime_before"], flush=True)
    for spp in args.spp:
        for rep in range(args.repeats):
            with tempfile.TemporaryDirectory(prefix="dask-bench-") as d:
                tmp = Path(d)
                run = {"spp": spp, "repeat": rep, "uptime": uptime()}
                run["sweep_serial"] = sweep_serial(args.size, spp, tmp)
                run["sweep_dask"] = sweep_dask(args.size, spp, args.workers, tmp)
                run["sweep_speedup"] = run["sweep_serial"]["wall_s"] / run["sweep_dask"]["wall_s"]
                run["references_only"] = references_only(args.size, spp, args.workers, tmp)
                run["uptime_after"] = uptime()
                out["runs"].append(run)
                print(json.dumps(run), flush=True)
    out["overhead"] = overhead_per_task(args.workers)
    print(json.dumps(out["overhead"]), flush=True)
    out["uptime_after"] = uptime()
    print(out["uptime_after"])
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":  # the workers are spawned: they import this file as __mp_main__ and must not run it
    main()
