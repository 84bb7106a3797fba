"""What one row costs in tone mapping, SSIM, FLIP and real-time rendering, per measuring path.

    PYTHONPATH=. .venv/bin/python benchmarks/measure_pair.py [--size 192] [--repeats 5] [--json out.json]

Runs, on one scene at the paper's size (192 x 192; the paper's 30 timed frames and 3 warm-up frames),
each path that measures a pair: a sweep/paper row (`sweep.run_row`: the metrics and the pictures), the
gate with its noise estimates (`gate.measure(noise=True)`), `iblcheck compare` (`gate.measure(noise=False)`),
and the follow-up of E1/E3/E9 that needs a row's real-time image and error map again (`image_of`:
render it again with one frame, then tone-map both images; or read the row's measured.npz when the
row kept one). Every call of the expensive steps is counted and timed by wrapping them where the
paths find them (`metrics.display`, `metrics.flip_map`, scikit-image's `structural_similarity`,
`realtime.render`); the reference is rendered once beforehand into a temporary cache and is read
from it in every repeat. Reports per path the median over the repeats of the calls and milliseconds
of each step, and the path's wall time.

The same file runs against an older checkout (PYTHONPATH pointing there) to give the figures before
a change. With Mesa's llvmpipe (software OpenGL) every time here, the real-time render included, is
CPU time on this machine, not GPU time.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import skimage.metrics

import groundtruth
import realtime
import scenes
from experiments.measure import metrics
from experiments.runs import gate, sweep
from realtime.engine.context import renderer_name

SPEC = "builtin:sphere-blend"


class Counter:
    """Wraps the expensive steps: calls and milliseconds per step since the last `reset`."""

    def __init__(self) -> None:
        self.calls: dict[str, int] = defaultdict(int)
        self.ms: dict[str, float] = defaultdict(float)

    def wrap(self, name: str, fn):
        def wrapper(*a, **k):
            t0 = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                self.calls[name] += 1
                self.ms[name] += (time.perf_counter() - t0) * 1e3
        return wrapper

    def install(self) -> None:
        metrics.display = self.wrap("tone mapping", metrics.display)
        metrics.flip_map = self.wrap("FLIP", metrics.flip_map)
        ssim = self.wrap("SSIM", skimage.metrics.structural_similarity)
        skimage.metrics.structural_similarity = ssim  # where the metrics looked it up at call time before
        if hasattr(metrics, "structural_similarity"):
            metrics.structural_similarity = ssim  # where they look it up now
        realtime.render = self.wrap("real-time render", realtime.render)

    def reset(self) -> None:
        self.calls.clear()
        self.ms.clear()


def image_of_again(row, out: Path) -> None:
    """E1/E3/E9's follow-up as it was: render the row's real-time image again (one frame), read the
    cached reference, tone-map both for the error map."""
    sc = scenes.load(row.spec).with_overrides({**row.overrides, "realtime.timing_frames": 1,
                                               "realtime.warmup_frames": 0})
    test = realtime.render(sc)
    ref = groundtruth.render(sc)
    mask = metrics.common_mask(test.mask, ref.mask)
    err = abs(metrics.display(sc, test.rgb) - metrics.display(sc, ref.rgb)).mean(-1)
    assert err.shape == mask.shape


def image_of_kept(row, out: Path) -> bool:
    """The follow-up from what the row kept (measured.npz); False where this checkout keeps nothing."""
    try:
        from experiments.publish.images import load_measured
    except ImportError:
        return False
    kept = load_measured(out, row)
    if kept is None:
        return False
    assert kept.error.shape == kept.mask.shape
    return True


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=192)
    ap.add_argument("--spp", type=int, default=64, help="the reference's spp (rendered once, then cached)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="iblcheck-bench-measure-"))
    os.environ["IBLCHECK_CACHE"] = str(tmp / "cache")
    overrides = {"camera.width": args.size, "camera.height": args.size, "reference.spp": args.spp,
                 "realtime.timing_frames": 30, "realtime.warmup_frames": 3}
    scene = scenes.load(SPEC).with_overrides(overrides)
    groundtruth.render(scene)  # the reference and its second seed into the cache, outside the timings
    gate.measure(scene, noise=False)
    counter = Counter()
    counter.install()
    rows_out = tmp / "rows"

    def sweep_row():
        return sweep.run_row(rows_out, SPEC, overrides)

    row = sweep_row()
    paths = {
        "sweep/paper row (run_row)": sweep_row,
        "gate with noise estimates": lambda: gate.measure(scene, noise=True),
        "compare (gate.measure, noise=False)": lambda: gate.measure(scene, noise=False),
        "E1/E3/E9 follow-up per row": (lambda: image_of_kept(row, rows_out) or image_of_again(row, rows_out)),
    }
    result: dict = {"gl": renderer_name(), "size": args.size, "repeats": args.repeats, "spec": SPEC,
                    "cwd_code": str(Path(metrics.__file__).resolve().parents[2]), "paths": {}}
    for name, fn in paths.items():
        fn()  # warm (shader compilation, caches)
        runs = []
        for _ in range(args.repeats):
            counter.reset()
            t0 = time.perf_counter()
            fn()
            wall = (time.perf_counter() - t0) * 1e3
            runs.append((dict(counter.calls), dict(counter.ms), wall))
        steps = sorted({k for c, _, _ in runs for k in c})
        result["paths"][name] = {
            "wall_ms": statistics.median(w for _, _, w in runs),
            "steps": {k: {"calls": statistics.median(c.get(k, 0) for c, _, _ in runs),
                          "ms": statistics.median(m.get(k, 0.0) for _, m, _ in runs)} for k in steps}}
    print(f"{result['gl']}; {args.size}x{args.size}; medians of {args.repeats}; code from {result['cwd_code']}")
    for name, p in result["paths"].items():
        cells = ", ".join(f"{k} {v['calls']:g}x {v['ms']:.1f} ms" for k, v in p["steps"].items())
        print(f"{name:38s} wall {p['wall_ms']:8.1f} ms | {cells or 'none of the steps'}")
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
