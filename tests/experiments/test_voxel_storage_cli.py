"""`iblcheck voxel-storage` and E10's voxel storage part: a glTF quad whose voxel count is known by hand,
the structures agreeing on the voxel set, the dense and cascaded bytes by formula, bad inputs as exit 2
with one line naming the value, and the QUICK paper part (its figure, tables and verdict sentences)."""

from __future__ import annotations

import base64
import json
import struct
from pathlib import Path

import pytest

from experiments.cli import main as cli
from experiments.paper import e10_voxel_storage


def quad_gltf(path: Path) -> Path:
    """A glTF of one quad at y = 0.25 spanning x, z in [0, 1] (two triangles, facing up)."""
    positions = struct.pack("<12f", 0, 0.25, 0, 1, 0.25, 0, 1, 0.25, 1, 0, 0.25, 1)
    indices = struct.pack("<6H", 0, 2, 1, 0, 3, 2)
    data = positions + indices
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
           "buffers": [{"byteLength": len(data),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                           {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                          "min": [0, 0.25, 0], "max": [1, 0.25, 1]},
                         {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]}
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("r", [8, 16])
def test_gltf_quad_by_hand(tmp_path, capsys, r):
    # the cube grid is centred on the quad's box, so y = 0.25 is its middle grid plane: the closed voxels on
    # both sides touch the quad, 2 layers of r x r voxels (the quad spans the cube's x and z up to its margin)
    assert cli.main(["voxel-storage", str(quad_gltf(tmp_path / "q.gltf")), "--resolutions", str(r),
                     "--cascades", "2", "--json", "--repeats", "1"]) == 0
    rows = {row["structure"]: row for row in json.loads(capsys.readouterr().out)}
    assert rows["voxelize"]["occupied"] == 2 * r * r
    for s in ("svo", "morton", "svdag", "dense"):
        assert rows[s]["occupied"] == 2 * r * r
    assert rows["dense"]["bytes"] == r ** 3 * 48
    assert rows["cascaded"]["bytes"] == 2 * (r // 2) ** 3 * 48
    # the finest cascade (the central (r/2)^3 of the fine grid) holds the quad's central r/2 x r/2 columns
    assert rows["cascaded"]["covered"] == pytest.approx(2 * (r // 2) ** 2 / (2 * r * r))


def test_atrium_table_and_figure(tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main(["voxel-storage", "atrium:1x1", "--resolutions", "16,32", "--repeats", "1", "--out",
                     str(out)]) == 0
    text = capsys.readouterr().out
    assert "atrium:1x1: 1288 triangles" in text and "svdag" in text and "seed's claim" in text
    assert (out / "voxel_storage.png").stat().st_size > 10_000
    rows = json.loads((out / "rows.json").read_text())
    assert {r["resolution"] for r in rows} == {16, 32}


def test_builtin_scene(capsys):
    assert cli.main(["voxel-storage", "builtin:sphere-diffuse", "--resolutions", "16", "--json",
                     "--repeats", "1"]) == 0
    rows = {r["structure"]: r for r in json.loads(capsys.readouterr().out)}
    # a sphere's shell at 16^3: more voxels than a great circle's, fewer than the whole grid
    assert 16 * 3 < rows["svo"]["occupied"] < 16 ** 3


@pytest.mark.parametrize("argv, says", [
    (["atrium:huge"], "'huge'"),
    (["atrium:1x1", "--resolutions", "12"], "12"),
    (["atrium:1x1", "--resolutions", "4"], "4"),
    (["atrium:1x1", "--resolutions", "2048"], "2048"),
    (["atrium:1x1", "--resolutions", "a,b"], "--resolutions"),
    (["atrium:1x1", "--cascades", "0"], "--cascades 0"),
    (["atrium:0x1"], "bays = 0"),
    (["missing.glb"], "missing.glb"),
    (["builtin:nosuch"], "builtin:nosuch"),
])
def test_bad_input_is_exit_2_with_one_line(capsys, argv, says):
    assert cli.main(["voxel-storage", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and says in err[0]


def test_bad_gltf_names_the_file(tmp_path, capsys):
    bad = tmp_path / "bad.gltf"
    bad.write_text("{not json")
    assert cli.main(["voxel-storage", str(bad)]) == 2
    assert "bad.gltf" in capsys.readouterr().err


def test_quick_paper_part(tmp_path):
    part = e10_voxel_storage.run(tmp_path, e10_voxel_storage.QUICK)
    assert part.figure == tmp_path / e10_voxel_storage.FIGURE and part.figure.stat().st_size > 10_000
    # 2 resolutions x (2 voxelisations + 5 structures) rows of the one atrium
    assert len(part.rows) == 2 * 7 and all(len(r) == len(part.header) for r in part.rows)
    assert len(part.size_rows) == 1 and len(part.size_rows[0]) == len(part.size_header)
    # the dense / cascaded ratio is 8^(c-1) / c = 64 / 3 whatever the scene: the cascades hold c (R/4)^3 voxels
    dense = next(t for t in part.verdict.trends if t.structure == "dense")
    assert dense.by_resolution == pytest.approx((64 / 3, 64 / 3))
    assert any("seed's claim" in line for line in part.lines)
    assert part.verdict.holds is None  # one scene size: not decided


def test_quick_part_steps_as_counted(tmp_path):
    steps, lines = [], []
    e10_voxel_storage.run(tmp_path, e10_voxel_storage.QUICK, step=lambda: steps.append(1), log=lines.append)
    assert len(steps) == e10_voxel_storage.count_steps(e10_voxel_storage.QUICK) == 2
    assert all("voxels" in line for line in lines)
