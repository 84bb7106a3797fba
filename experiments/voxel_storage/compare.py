"""The comparison: one scene's triangles voxelised at each resolution, the one voxel set stored in every
structure (dense, cascaded, svo, morton, svdag), each measured in voxels, nodes, bytes and build time;
and whether the seed's claim (the cascades' advantage grows with resolution and scene size) holds.

Build times (time.perf_counter, the median of `repeats` where the voxel set is small, else one run) start
from the voxel set (sorted linear ids) and include every step the structure needs from there: the SVO
sorts the Morton codes itself, the DAG is timed as the SVO plus the merging. The voxelisation, shared by
all, is its own row ("voxelize"); the cascades' own voxelisation (the triangles into each cascade's
grid, as the seed's GPU does) is the row "voxelize-cascades".

The advantage of the cascades over a structure S is bytes(S) / bytes(cascaded) at equal finest voxel
(experiments/voxel_storage/cascaded.py): the claim holds for S when that ratio grows with the resolution
(on the largest scene) and with the scene's size (at the highest resolution).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

from experiments.voxel_storage import cascaded, dag, dense, morton_octree, octree
from experiments.voxel_storage.footprint import Footprint
from experiments.voxel_storage.voxelize import Grid, VoxelSet, cube_grid, voxelize

STRUCTURES = ("dense", "cascaded", "svo", "morton", "svdag")
#: the structures the cascades are compared with
OTHERS = ("dense", "svo", "morton", "svdag")
RESOLUTIONS = (32, 64, 128, 256, 512)
#: a voxel set above this many voxels is built once, not `repeats` times
REPEAT_LIMIT = 200_000


@dataclass(frozen=True)
class Row:
    scene: str
    triangles: int
    resolution: int
    structure: str  # one of STRUCTURES, or "voxelize"
    cells: int
    occupied: int
    nodes: int
    bytes: int
    bytes_geometry: int
    build_s: float | None  # None: not built (a dense grid above its allocation limit), bytes by formula
    finest_voxel: float
    covered: float
    nodes_per_level: tuple[int, ...]

    def to_dict(self) -> dict:
        d = asdict(self)
        d["nodes_per_level"] = list(self.nodes_per_level)
        return d


def triangles_of(positions: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """(F, 3, 3) float64 corner positions."""
    return np.asarray(positions, dtype=np.float64)[np.asarray(indices, dtype=np.int64)]


def timed(fn: Callable[[], object], repeats: int) -> tuple[object, float]:
    """(fn's result, the median of `repeats` runs' seconds)."""
    times, result = [], None
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return result, statistics.median(times)


def structures(voxels: VoxelSet, grid: Grid, cascades: int, repeats: int) -> list[tuple[Footprint, float | None]]:
    """Every structure of the voxel set: (its footprint, its build seconds)."""
    reps = repeats if voxels.count <= REPEAT_LIMIT else 1
    h = grid.voxel
    out = []
    occupancy, t = timed(lambda: dense.build(voxels), reps)
    out.append((dense.footprint(voxels, h), t if occupancy is not None else None))
    del occupancy
    grids, t = timed(lambda: cascaded.build(voxels, cascades), reps)
    out.append((cascaded.footprint(grids, voxels, h), t))
    tree, t = timed(lambda: octree.build(voxels), reps)
    out.append((octree.footprint(tree, h), t))
    codes, t = timed(lambda: morton_octree.build(voxels), reps)
    out.append((morton_octree.footprint(codes, h), t))
    d, t = timed(lambda: dag.build(octree.build(voxels)), reps)
    out.append((dag.footprint(d, h), t))
    return out


def measure(scene: str, triangles: np.ndarray, resolutions=RESOLUTIONS, cascades: int = 3, repeats: int = 3,
            progress: Callable[[str], None] | None = None) -> list[Row]:
    """The rows of one scene: per resolution the voxelisation and every structure."""
    lo, hi = triangles.reshape(-1, 3).min(axis=0), triangles.reshape(-1, 3).max(axis=0)
    rows = []
    for r in resolutions:
        grid = cube_grid(lo, hi, r)
        cascaded.layout(grid, cascades)  # refuse a resolution the cascades cannot split before voxelising
        voxels, t = timed(lambda g=grid: voxelize(triangles, g), 1)
        n = voxels.count
        rows.append(Row(scene, len(triangles), r, "voxelize", n, n, 0, 0, 0, t, grid.voxel, 1.0, ()))
        direct, t_direct = timed(lambda g=grid: cascaded.voxelize_direct(triangles, g, cascades), 1)
        counts = tuple(v.count for v in direct)
        rows.append(Row(scene, len(triangles), r, "voxelize-cascades", sum(counts), sum(counts), 0, 0, 0, t_direct,
                        grid.voxel, 1.0, counts))
        for fp, build_s in structures(voxels, grid, cascades, repeats):
            rows.append(Row(scene, len(triangles), r, fp.structure, fp.cells, fp.occupied, fp.nodes, fp.bytes,
                            fp.bytes_geometry, build_s, fp.finest_voxel, fp.covered, fp.nodes_per_level))
        if progress:
            progress(f"{scene} {r}^3: {n} voxels, voxelised in {t:.2f} s, into the cascades in {t_direct:.2f} s")
    return rows


def find(rows: list[Row], scene: str, resolution: int, structure: str) -> Row:
    for r in rows:
        if (r.scene, r.resolution, r.structure) == (scene, resolution, structure):
            return r
    raise KeyError(f"{scene} {resolution} {structure}")


@dataclass(frozen=True)
class Trend:
    structure: str
    by_resolution: tuple[float, ...]  # bytes(S) / bytes(cascaded) on the largest scene, per resolution
    by_size: tuple[float, ...]  # the same at the highest resolution, per scene (fewest triangles first)

    @staticmethod
    def grows(values: tuple[float, ...]) -> bool | None:
        """Strictly increasing; None with fewer than two values (nothing measured)."""
        return all(b > a for a, b in zip(values, values[1:], strict=False)) if len(values) > 1 else None


@dataclass(frozen=True)
class Verdict:
    trends: tuple[Trend, ...]
    resolutions: tuple[int, ...]
    scenes: tuple[str, ...]  # fewest triangles first
    covered: float  # fraction of the largest scene's finest voxels inside cascade 0, at the highest resolution

    def holds_for(self, t: Trend) -> bool | None:
        """Whether the advantage over t's structure grows with both; None when either was not measured."""
        a, b = Trend.grows(t.by_resolution), Trend.grows(t.by_size)
        return None if a is None or b is None else a and b

    @property
    def holds(self) -> bool | None:
        each = [self.holds_for(t) for t in self.trends]
        return None if None in each else all(each)

    def sentences(self) -> list[str]:
        r0, r1 = self.resolutions[0], self.resolutions[-1]
        words = {True: "grows", False: "does not grow", None: "is not measured (one value)"}
        out = []
        for t in self.trends:
            res, size = words[Trend.grows(t.by_resolution)], words[Trend.grows(t.by_size)]
            out.append(f"{t.structure}: bytes / cascaded bytes {t.by_resolution[0]:.3g} at {r0}^3 -> "
                       f"{t.by_resolution[-1]:.3g} at {r1}^3 on {self.scenes[-1]} (with resolution it {res}); "
                       f"at {r1}^3 from {t.by_size[0]:.3g} ({self.scenes[0]}) to {t.by_size[-1]:.3g} "
                       f"({self.scenes[-1]}) (with scene size it {size})")
        claim = "The seed's claim (the cascades' advantage grows with resolution and scene size)"
        both = [t.structure for t in self.trends if self.holds_for(t)]
        if self.holds is None:
            out.append(f"{claim} is not decided: it needs at least two resolutions and two scene sizes")
        elif self.holds:
            out.append(f"{claim} holds against every structure")
        else:
            out.append(f"{claim} does not hold: the advantage grows in both directions against "
                       f"{', '.join(both) or 'none'} of {', '.join(t.structure for t in self.trends)}")
        out.append(f"At {r1}^3 the finest cascade holds {100 * self.covered:.1f}% of {self.scenes[-1]}'s "
                   "finest-voxel surface; the rest is stored 2x, 4x ... coarser")
        return out


def verdict(rows: list[Row]) -> Verdict:
    """The advantage ratios and whether they grow, from the rows of several scenes and resolutions."""
    scenes = sorted({r.scene for r in rows}, key=lambda s: next(r.triangles for r in rows if r.scene == s))
    resolutions = tuple(sorted({r.resolution for r in rows}))
    largest, top = scenes[-1], resolutions[-1]
    trends = []
    for s in OTHERS:
        by_res = tuple(find(rows, largest, r, s).bytes / find(rows, largest, r, "cascaded").bytes
                       for r in resolutions)
        by_size = tuple(find(rows, sc, top, s).bytes / find(rows, sc, top, "cascaded").bytes for sc in scenes)
        trends.append(Trend(s, by_res, by_size))
    return Verdict(tuple(trends), resolutions, tuple(scenes), find(rows, largest, top, "cascaded").covered)
