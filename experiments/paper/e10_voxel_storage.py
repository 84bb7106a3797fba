"""E10's voxel storage part: the seed's comparison of its cascaded texture with a dense 3D texture, a
sparse voxel octree, a Morton-ordered sparse octree and a sparse voxel DAG, in stored voxels, build time
and memory against resolution, on procedural atriums of growing size (scenes/geometry/atrium.py: about
1e4 ... 2e6 triangles), and whether its claim holds: that the cascades' advantage grows with resolution
and scene size. The structures, the comparison at equal finest voxel and the ratios the verdict is
computed from: experiments/voxel_storage/.

`run` returns the part's lines, its tables and its figure; E10 (experiments/paper/e10_voxel_cone_tracing.py)
places them in its section. QUICK: the 1e4-triangle atrium at 32^3 and 64^3 (seconds); FULL: four atriums
at 32^3 ... 512^3 (minutes). The dense grid at 48 bytes a voxel is counted by formula, never allocated.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from experiments.voxel_storage import compare, figure
from experiments.voxel_storage.compare import Row, Verdict
from scenes.geometry import atrium


@dataclass(frozen=True)
class Settings:
    sizes: tuple[str, ...]  # atrium.SIZES names, fewest triangles first
    resolutions: tuple[int, ...]
    cascades: int
    repeats: int  # build-time repeats (median) where the voxel set is small


QUICK = Settings(sizes=("10k",), resolutions=(32, 64), cascades=3, repeats=1)
FULL = Settings(sizes=("10k", "100k", "1M", "2M"), resolutions=compare.RESOLUTIONS, cascades=3, repeats=3)
FIGURE = "figures/e10_voxel_storage.png"
HEADER = ["resolution", "structure", "stored voxels", "set voxels", "inner nodes", "MB (48 B payload)",
          "MB (geometry)", "build ms", "finest voxel (cm)", "finest voxels held"]
SIZE_HEADER = ["atrium", "triangles", "set voxels"] + [f"{s} / cascaded bytes" for s in compare.OTHERS] + \
              ["finest voxels held by cascade 0"]


@dataclass(frozen=True)
class Part:
    lines: list[str]  # prose: what was measured and the verdict, computed from the ratios
    header: list[str]
    rows: list[list[str]]  # the largest atrium: every resolution and structure
    size_header: list[str]
    size_rows: list[list[str]]  # every atrium at the highest resolution
    figure: Path
    data: list[Row]
    verdict: Verdict


def count_steps(settings: Settings) -> int:
    return len(settings.sizes) * len(settings.resolutions)


def measure(settings: Settings, step: Callable[[], None] | None = None,
            log: Callable[[str], None] | None = None) -> list[Row]:
    """Every atrium at every resolution; `step()` after each (count_steps in all; the paper's Context.progress),
    `log(line)` with its voxel count and voxelisation times."""

    def done(line: str) -> None:
        if log:
            log(line)
        if step:
            step()

    rows: list[Row] = []
    for size in settings.sizes:
        mesh = atrium.atrium_of_size(size)
        tris = compare.triangles_of(mesh.positions, mesh.indices)
        rows += compare.measure(f"atrium {size}", tris, settings.resolutions, settings.cascades, settings.repeats,
                                done)
    return rows


def run(out_dir: Path, settings: Settings, step: Callable[[], None] | None = None,
        log: Callable[[str], None] | None = None) -> Part:
    """Measure, plot into out_dir/FIGURE and return the part."""
    rows = measure(settings, step, log)
    return part(rows, figure.plot(rows, Path(out_dir) / FIGURE), settings)


def _mb(n: int) -> str:
    return f"{n / 1e6:.4g}"


def table_row(r: Row) -> list[str]:
    if r.structure in ("voxelize", "voxelize-cascades"):  # a voxelisation: its time and the set's size, no storage
        return [f"{r.resolution}^3", r.structure, "-", str(r.occupied), "-", "-", "-", f"{1e3 * r.build_s:.3g}",
                f"{100 * r.finest_voxel:.3g}", "-"]
    return [f"{r.resolution}^3", r.structure, str(r.cells), str(r.occupied), str(r.nodes), _mb(r.bytes),
            _mb(r.bytes_geometry), "n/a" if r.build_s is None else f"{1e3 * r.build_s:.3g}",
            f"{100 * r.finest_voxel:.3g}", f"{100 * r.covered:.3g}%"]


def part(rows: list[Row], figure_path: Path, settings: Settings) -> Part:
    v = compare.verdict(rows)
    largest, top = v.scenes[-1], v.resolutions[-1]
    table = [table_row(r) for r in rows if r.scene == largest]
    size_rows = []
    for sc in v.scenes:
        cas = compare.find(rows, sc, top, "cascaded")
        size_rows.append([sc, str(cas.triangles), str(compare.find(rows, sc, top, "voxelize").cells)]
                         + [f"{compare.find(rows, sc, top, s).bytes / cas.bytes:.3g}" for s in compare.OTHERS]
                         + [f"{100 * cas.covered:.3g}%"])
    c = settings.cascades
    lines = [f"Voxel storage: the atriums {', '.join(v.scenes)} voxelised conservatively (triangle/box SAT) at "
             f"{', '.join(f'{r}^3' for r in v.resolutions)}; the one voxel set stored as a dense 3D texture, "
             f"{c} cascades of (R/{2 ** (c - 1)})^3 (the same finest voxel, the outermost over the whole scene), a "
             "pointer SVO, a Morton-ordered octree and an SVDAG, every voxel with VCT's 48-byte six-face payload "
             "(the DAG's payload cannot be shared and is stored per voxel). The 512^3 dense texture (6.4 GB) is "
             "counted by formula, not allocated."] + v.sentences()
    return Part(lines, HEADER, table, SIZE_HEADER, size_rows, figure_path, rows, v)
