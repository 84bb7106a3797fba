"""PRT precomputation cost (realtime/techniques/prt/prt_transfer.py): a ~20k-vertex torus at 256 rays, medians of
repeats.

    .venv/bin/python benchmarks/prt_precompute.py [--repeats 3]

Prints vertices, rays, order, bounces, median seconds and rays per second. The issue's aim: under 10 s
for 20k vertices at 256 rays on this machine (2 cores, Embree through embreex).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from realtime.techniques.prt.prt_transfer import TransferObject, transfer
from scenes.geometry import meshes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    mesh = meshes.torus(resolution=100)  # 2 x 100 x 100 quads' worth: about 20k vertices
    obj = TransferObject(mesh.positions.astype(np.float64), mesh.normals.astype(np.float64), mesh.indices,
                         (0.8, 0.8, 0.8))
    print(f"torus: {len(mesh.positions)} vertices, {len(mesh.indices)} triangles")
    for order, bounces in ((2, 0), (4, 0), (4, 2)):
        times = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            transfer([obj], order, 256, bounces, shadowed=True)
            times.append(time.perf_counter() - t0)
        med = statistics.median(times)
        rays = len(mesh.positions) * 256
        print(f"order {order}, 256 rays, {bounces} bounces: median {med:.2f} s over {args.repeats} "
              f"({rays / med / 1e6:.2f} M rays/s)")


if __name__ == "__main__":
    main()
