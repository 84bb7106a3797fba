"""How far the paper's 2x2 box chain is from the environment's mean radiance at each level, beside the chain
weighted by solid angle that voxel cone tracing reads.

    .venv/bin/python benchmarks/env_chain_solid_angle.py [--probes uffizi,wells,ennis] [--base 256]

A texel of level L should hold the mean radiance over the solid angle it covers. The box chain averages a texel's
four children alike, and a cube face's centre texel covers 3 sqrt(3) = 5.2 times a corner texel's solid angle, so
the coarse levels weigh the corners as the centres. For each probe (cube of `--base` texels a face, filled and
filtered on the GPU as a frame does) and each level, the level's texels weighted by their solid angle: their mean
radiance over the base level's (exact: 1), for the box chain and for `EnvironmentFilter.solid_angle_chain`.
"""

from __future__ import annotations

import argparse

import numpy as np

from realtime.engine.context import get_context
from realtime.engine.gpu import EnvironmentFilter
from scenes.environment import cubemap, environments


def level_mean(faces: np.ndarray) -> float:
    """The mean radiance (channels' mean) of cube faces (6, s, s, 3), each texel weighted by its solid angle."""
    omega = cubemap.texel_solid_angles(faces.shape[1])
    return float((faces.mean(-1) * omega).sum() / (6.0 * omega.sum()))


def chain_means(f: EnvironmentFilter) -> list[tuple[int, float, float]]:
    """Per level (level, box chain's mean over the base's, weighted chain's mean over the base's), the chain built."""
    base = level_mean(f.read_level(0))
    out = []
    for level in range(f.n_levels):
        w = f.read_level(level, weighted=True)
        out.append((level, level_mean(f.read_level(level)) / base, level_mean(w[..., :3] / w[..., 3:]) / base))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--probes", default="uffizi,wells,ennis", help="builtin environments, comma separated")
    ap.add_argument("--base", type=int, default=256, help="cube face size (a power of two)")
    args = ap.parse_args()
    ctx = get_context()
    print("| probe | " + " | ".join(f"level {k} ({args.base >> k}²)" for k in range(args.base.bit_length()))
          + " |")
    print("|---|" + "---|" * args.base.bit_length())
    for name in args.probes.split(","):
        f = EnvironmentFilter(ctx, environments.builtin(name), args.base)
        try:
            f.fill_base(0.0)
            f.build_chain()
            rows = chain_means(f)
        finally:
            f.release()
        print(f"| {name} | " + " | ".join(f"{box:.3f} ({weighted:.3f})" for _, box, weighted in rows) + " |")
    print("\nEach cell: the box chain's mean radiance over the environment's (the weighted chain's in parentheses).")


if __name__ == "__main__":
    main()
