"""`iblcheck voxel-storage SCENE_OR_GLTF`: one scene's voxels stored as a dense 3D texture, cascades, a
pointer SVO, a Morton-ordered octree and an SVDAG, with their voxel counts, bytes and build times
(experiments/voxel_storage/), at several resolutions; `--out DIR` adds the three-panel figure.

SCENE_OR_GLTF: `atrium:SIZE` (the procedural atrium, SIZE one of scenes/geometry/atrium.py's SIZES, or
BAYSxDETAIL), a glTF file (.gltf/.glb: every triangle primitive of its default scene, in world space,
no triangle limit), or a scene file / builtin:NAME (its objects' meshes). Every bad value is exit 2 with
one line naming the file, option or value.
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

import numpy as np

from experiments.cli.inputs import UsageError, load_scene, parse_list
from experiments.paper.e10_voxel_storage import HEADER, table_row
from experiments.publish import outputs
from experiments.publish.text import one_line
from experiments.voxel_storage import compare, figure
from scenes.exchange import gltf_reader
from scenes.geometry import atrium

DEFAULT_RESOLUTIONS = "32,64,128,256"
#: resolutions beyond this are refused (the dense occupancy grid and the voxel lists stay in memory)
MAX_RESOLUTION = 1024
MAX_CASCADES = 6
FIGURE = "voxel_storage.png"


def add_parser(sub) -> None:
    v = sub.add_parser("voxel-storage", help="voxel counts, bytes and build times of dense, cascaded, SVO, "
                       "Morton-octree and SVDAG storage of a scene's voxels")
    v.add_argument("scene", metavar="SCENE_OR_GLTF",
                   help="atrium:SIZE (10k, 100k, 1M, 2M or BAYSxDETAIL), a .gltf/.glb file, a scene file or "
                        "builtin:NAME")
    v.add_argument("--resolutions", help=f"comma-separated powers of two (default {DEFAULT_RESOLUTIONS})")
    v.add_argument("--cascades", type=int, default=3, help="cascades of the cascaded texture (default 3)")
    v.add_argument("--repeats", type=int, default=3, help="build-time repeats (median) for small voxel sets")
    v.add_argument("--json", action="store_true", help="print the rows as JSON")
    v.add_argument("--out", metavar="DIR", help=f"write DIR/{FIGURE} (the three panels) and DIR/rows.json")
    v.set_defaults(func=run)


def triangles(spec: str) -> tuple[str, np.ndarray]:
    """(a name, (F, 3, 3) triangles) of SCENE_OR_GLTF."""
    if spec.startswith("atrium:"):
        size = spec.partition(":")[2]
        m = re.fullmatch(r"(\d+)x(\d+)", size)
        mesh = atrium.atrium(int(m.group(1)), int(m.group(2))) if m else atrium.atrium_of_size(size)
        return spec, compare.triangles_of(mesh.positions, mesh.indices)
    if Path(spec).suffix.lower() in (".gltf", ".glb"):
        _, parts = gltf_reader.parts(Path(spec))
        return spec, np.concatenate([compare.triangles_of(p.positions, p.indices) for p in parts])
    scene = load_scene(spec)
    meshes = [o.mesh for o in scene.objects]
    return scene.name, np.concatenate([compare.triangles_of(m.positions, m.indices) for m in meshes])


def check_options(args: argparse.Namespace) -> list[int]:
    if not 1 <= args.cascades <= MAX_CASCADES:
        raise UsageError(f"--cascades {args.cascades}: must be 1 .. {MAX_CASCADES}")
    if args.repeats < 1:
        raise UsageError(f"--repeats {args.repeats}: must be at least 1")
    resolutions = parse_list(DEFAULT_RESOLUTIONS if args.resolutions is None else args.resolutions, int,
                             "--resolutions")
    for r in resolutions:
        # a power of two (the octrees), each cascade at least 2 voxels wide (r >= 2^cascades)
        if r < 2 ** args.cascades or r > MAX_RESOLUTION or r & (r - 1):
            raise UsageError(f"--resolutions: {r}: each must be a power of two from 2^cascades = "
                             f"{2 ** args.cascades} to {MAX_RESOLUTION}")
    return sorted(set(resolutions))


def text_table(header: list[str], rows: list[list[str]]) -> str:
    """Columns padded to their widest cell, numbers right-aligned."""
    widths = [max(len(str(c)) for c in col) for col in zip(header, *rows, strict=True)]

    def line(row: list[str]) -> str:
        cells = zip(row, widths, strict=True)
        return "  ".join(str(c).rjust(w) if i > 1 else str(c).ljust(w) for i, (c, w) in enumerate(cells))

    return "\n".join(line(r) for r in [header] + rows)


def run(args: argparse.Namespace) -> int:
    resolutions = check_options(args)
    with outputs.Outputs() as plan:
        folder = plan.folder(args.out, "--out") if args.out else None
        name, tris = triangles(args.scene)
        rows = compare.measure(name, tris, resolutions, args.cascades, args.repeats)
        if folder is not None:
            figure.plot(rows, folder / FIGURE)
            outputs.write_text(folder / "rows.json", json.dumps([r.to_dict() for r in rows], indent=1))
    if args.json:
        print(json.dumps([r.to_dict() for r in rows], allow_nan=False))
    else:
        print(one_line(f"{name}: {len(tris)} triangles", 300))
        print(text_table(HEADER, [table_row(r) for r in rows]))
        for line in compare.verdict(rows).sentences():
            print(one_line(line, 1000))
    return 0
