"""Voxel cone tracing's diffuse cones one at a time under a sphere above a plane, each against the share of its own
cap the sphere blocks.

    .venv/bin/python benchmarks/vct_sphere_cones.py [--heights 1.5,1.0] [--resolutions 32,64,128] [--starts 1,3,6,10,15]

builtin:sphere-on-plane (a sphere of radius 0.5 over the plane y = 0) with the sphere's centre at each height; from
the plane's point under it, normal +y, the six cones of the shading's diffuse read (`vct_trace.glsl`'s
`vct_diffuse`: the same origin, start, aperture and frame) traced apart through one cascade
(`VoxelScene.trace_cone`). Each cone's opacity is printed beside its exact share: the fraction of its cap's
directions whose ray meets the sphere (`blocked_share`), and beside the opacity it reads when started further out
(`--starts`, in voxels), which tells where along it the opacity comes from. The first line of each block gives the
whole read's blocked share of the cosine lobe, 1 - V, against the exact sin^2 of the sphere's angular radius.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import scenes
from realtime.engine.context import get_context
from realtime.engine.environment_maps import filled_store
from realtime.techniques.vct import vct_math
from realtime.techniques.vct.vct import NORMAL_OFFSET_VOXELS, START_OFFSET_VOXELS, VoxelScene

RADIUS = 0.5


def blocked_share(axis: np.ndarray, half_angle: float, centre: np.ndarray, radius: float,
                  origin: np.ndarray, samples: int = 200_000, seed: int = 1) -> float:
    """The fraction of the cap of `half_angle` about `axis` (directions uniform in solid angle) whose rays from
    `origin` meet the sphere (`centre`, `radius`) in front of it: Monte Carlo over `samples` directions."""
    a = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    d = vct_math.cap_directions(a[None], half_angle, samples, np.random.default_rng(seed))[0]
    oc = np.asarray(origin, dtype=np.float64) - centre
    half_b = d @ oc
    disc = half_b * half_b - (oc @ oc - radius * radius)
    hit = (disc > 0.0) & (-half_b - np.sqrt(np.maximum(disc, 0.0)) > 0.0)
    return float(hit.mean())


def cones_under_sphere(ctx, height: float, resolution: int, starts: list[float]) -> dict:
    """The six cones' reads from the plane's point under a sphere centred at `height` (one cascade)."""
    scene = scenes.load("builtin:sphere-on-plane").with_overrides({"objects.0.translate": [0.0, height, 0.0]})
    env = filled_store(ctx, scene)
    vs = None
    try:
        vs = VoxelScene(ctx, scene.objects, resolution, 1, 6, 0.5)
        vs.update(None, env.sh_buffer)
        h = vs.grid.voxel_size
        x, n = np.zeros(3), np.array([0.0, 1.0, 0.0])
        dirs = vs.cones.directions @ vct_math.tangent_frame(n)  # rows t, b, n: as vct_trace.glsl's vct_frame
        k = len(dirs)
        origin = x + NORMAL_OFFSET_VOXELS * h * n
        tan_half = np.full(k, math.tan(vs.cones.half_angle))

        def trace(start_voxels: float) -> np.ndarray:
            return vs.trace_cone(np.tile(origin, (k, 1)), dirs, tan_half, np.full(k, start_voxels * h),
                                 np.tile(x, (k, 1)), np.tile(n, (k, 1)))[:, 3]

        centre = np.array([0.0, height, 0.0])
        return {"voxel": h, "blocked": 1.0 - float(vs.probe(x[None], n[None])[0, 3]),
                "exact": (RADIUS / height) ** 2, "directions": dirs, "weights": vs.cones.weights / math.pi,
                "opacity": trace(START_OFFSET_VOXELS), "by_start": {s: trace(s) for s in starts},
                "share": np.array([blocked_share(d, vs.cones.half_angle, centre, RADIUS, x) for d in dirs])}
    finally:
        if vs is not None:
            vs.release()
        env.release()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--heights", default="1.5,1.0", help="the sphere's centre above the plane, comma separated")
    ap.add_argument("--resolutions", default="32,64,128", help="voxels a side, comma separated")
    ap.add_argument("--starts", default="1,3,6,10,15", help="later starts, in voxels, comma separated")
    args = ap.parse_args()
    ctx = get_context()
    starts = [float(s) for s in args.starts.split(",")]
    for height in (float(v) for v in args.heights.split(",")):
        for res in (int(v) for v in args.resolutions.split(",")):
            r = cones_under_sphere(ctx, height, res, starts)
            own = float(r["weights"] @ r["share"])
            print(f"centre {height} at {res}^3 (voxel {r['voxel']:.4f}): blocked {r['blocked']:.3f}, exact "
                  f"{r['exact']:.3f}; each cone at its own share {own:.3f}")
            for i, d in enumerate(r["directions"]):
                later = " ".join(f"{s:g}:{r['by_start'][s][i]:.2f}" for s in starts)
                print(f"  cone {i} ({d[0]:+.2f}, {d[1]:+.2f}, {d[2]:+.2f}) weight {r['weights'][i]:.3f}: opacity "
                      f"{r['opacity'][i]:.3f}, its share {r['share'][i]:.3f}; started later (voxels) {later}")


if __name__ == "__main__":
    main()
