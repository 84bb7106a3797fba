"""The seed's three panels (stored voxels, build time, memory against resolution, one line style per
structure) for the largest scene, and a fourth for scene size: each structure's bytes over the
cascades' at the highest resolution against the triangle count."""

from __future__ import annotations

from pathlib import Path

from experiments.publish.plots import label_text, pyplot, save
from experiments.voxel_storage.compare import OTHERS, STRUCTURES, Row, find

#: one line style per structure (and the shared voxelisation)
STYLE = {"dense": ("tab:gray", "s", "-"), "cascaded": ("tab:red", "o", "-"), "svo": ("tab:blue", "^", "--"),
         "morton": ("tab:green", "v", "-."), "svdag": ("tab:purple", "D", ":"), "voxelize": ("black", "x", "-"),
         "voxelize-cascades": ("tab:red", "x", ":")}


def plot(rows: list[Row], path: Path) -> Path:
    plt = pyplot()
    scenes = sorted({r.scene for r in rows}, key=lambda s: next(r.triangles for r in rows if r.scene == s))
    largest = scenes[-1]
    resolutions = sorted({r.resolution for r in rows})
    fig, axes = plt.subplots(1, 4, figsize=(17, 4.2))
    panels = (("stored voxels (cells or leaves)", lambda r: r.cells, STRUCTURES),
              ("build time from the voxel set (s)", lambda r: r.build_s,
               ("voxelize", "voxelize-cascades") + STRUCTURES),
              ("memory, 48 B payload per voxel (bytes)", lambda r: r.bytes, STRUCTURES))
    for ax, (title, value, names) in zip(axes, panels, strict=False):
        for s in names:
            pts = [(res, value(find(rows, largest, res, s))) for res in resolutions]
            pts = [(x, y) for x, y in pts if y is not None and y > 0]
            if pts:
                colour, marker, line = STYLE[s]
                ax.plot(*zip(*pts, strict=True), color=colour, marker=marker, linestyle=line, label=s)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xticks(resolutions, [str(r) for r in resolutions])
        ax.set_xlabel("resolution (voxels per side, finest)")
        ax.set_title(f"{title}\n{label_text(largest)}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    ax = axes[3]
    top = resolutions[-1]
    tris = [next(r.triangles for r in rows if r.scene == s) for s in scenes]
    for s in OTHERS:
        colour, marker, line = STYLE[s]
        ax.plot(tris, [find(rows, sc, top, s).bytes / find(rows, sc, top, "cascaded").bytes for sc in scenes],
                color=colour, marker=marker, linestyle=line, label=s)
    ax.axhline(1.0, color="tab:red", linewidth=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("atrium triangles")
    ax.set_title(f"bytes / cascaded bytes at {top}^3 (above 1: cascades smaller)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    save(fig, path)
    return Path(path)
