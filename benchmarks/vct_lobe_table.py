"""How far voxel cone tracing's glossy environment reads are from the lobe's integral: the chain read at the level
whose texel covers the lobe (vct_glossy_env.glsl's `vct_chain_env`) beside the broad-lobe table
(realtime/techniques/vct/lobe_table.py), and what the table costs to build.

    .venv/bin/python benchmarks/vct_lobe_table.py [--probes ennis,uffizi,...] [--exponents 0,1,...] [--directions 3000]

For each probe (a cube of 256 texels a face, filled and filtered on the GPU as a frame does) and each Phong
exponent N, the reads along `--directions` random directions (`VoxelScene.read_environment`, as the cones read
them) against the lobe's integral (N + 1) / (2 pi) int L(w) max(r . w, 0)^N dw, summed in float64 over the base
level reduced to 64 texels a face by solid-angle-weighted sums (`vct_math.lobe_integrals`): RMS error over the
directions, as a fraction of the environment's mean radiance. Then the table's build time on this machine (median of 5).
"""

from __future__ import annotations

import argparse
import statistics
import time
from types import SimpleNamespace

import moderngl
import numpy as np

import scenes
from realtime.engine.context import get_context
from realtime.engine.gpu import EnvironmentFilter
from realtime.techniques.vct.vct import VoxelScene
from realtime.techniques.vct.vct_math import lobe_integrals, reduced_faces
from scenes.environment import environments

BASE = 256


def random_axes(n: int, seed: int = 1) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def glossy_voxel_scene(ctx: moderngl.Context, env_filter: EnvironmentFilter) -> VoxelScene:
    """A voxelised Phong plane (a glossy surface: the scene reads the environment), for its environment probe."""
    plane = scenes.load("builtin:sphere-on-plane").objects[1]
    material = scenes.load("builtin:torus-phong").objects[0].material
    vs = VoxelScene(ctx, [SimpleNamespace(mesh=plane.mesh, material=material)], 16, 1, 6, 0.5,
                    env_filter=env_filter)
    vs.update(None, env_filter.sh_buffer)
    return vs


def errors(name: str, exponents: list[float], n_axes: int) -> tuple[list[float], list[float], float]:
    """(the chain's, the table's RMS errors over the mean radiance per exponent, the table's build in ms)."""
    ctx = get_context()
    f = EnvironmentFilter(ctx, environments.builtin(name), BASE)
    vs = None
    try:
        f.fill_base(0.0)
        f.build_chain()
        f.project_sh(64)
        vs = glossy_voxel_scene(ctx, f)
        faces = f.read_level(0)
        _, omega, radiance = reduced_faces(faces, 64)
        mean = float(radiance.mean(-1) @ omega) / (4.0 * np.pi)
        axes = random_axes(n_axes)
        chain, table = [], []
        for n in exponents:
            exact = lobe_integrals(faces, axes, n).mean(-1)
            for out, use_table in ((chain, False), (table, True)):
                read = vs.read_environment(axes, np.full(len(axes), n), table=use_table).mean(-1)
                out.append(float(np.sqrt(np.mean((read - exact) ** 2)) / mean))
        times = []
        for _ in range(5):
            f.fill_base(0.0)
            f.solid_angle_chain()
            ctx.finish()
            t0 = time.perf_counter()
            vs.lobe_table.build()
            ctx.finish()
            times.append((time.perf_counter() - t0) * 1e3)
        return chain, table, statistics.median(times)
    finally:
        if vs is not None:
            vs.release()
        f.release()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--probes", default="ennis,uffizi,wells,pisa,studio", help="builtin environments")
    ap.add_argument("--exponents", default="0,1,2,4,8,16,32,50,127", help="Phong exponents N")
    ap.add_argument("--directions", type=int, default=3000, help="random lobe axes")
    args = ap.parse_args()
    exponents = [float(v) for v in args.exponents.split(",")]
    print("RMS error of the read over the lobe's integral, as a fraction of the environment's mean radiance "
          f"({args.directions} random axes; cube of {BASE} texels a face). Build times on this machine's OpenGL "
          f"({get_context().info['GL_RENDERER']}; llvmpipe's are CPU times).\n")
    print("| probe | read | " + " | ".join(f"N = {n:g}" for n in exponents) + " |")
    print("|---|---|" + "---|" * len(exponents))
    for name in args.probes.split(","):
        chain, table, ms = errors(name, exponents, args.directions)
        print(f"| {name} | chain | " + " | ".join(f"{e:.3f}" for e in chain) + " |")
        print(f"| {name} | table (build {ms:.0f} ms) | " + " | ".join(f"{e:.3f}" for e in table) + " |")


if __name__ == "__main__":
    main()
