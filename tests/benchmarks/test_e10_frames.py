"""benchmarks/gpu/e10_frames.py: which rows it times, and how it sets a GPU run beside an llvmpipe run.

No GL here: the rows come from E10's settings, and `compare` reads folders written by hand."""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

import scenes
from experiments.measure import metrics

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("e10_frames", ROOT / "benchmarks" / "gpu" / "e10_frames.py")
e10_frames = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = e10_frames  # its dataclass looks its module up there
_spec.loader.exec_module(e10_frames)


def test_row_key_ignores_the_order_of_the_overrides_and_names_the_size():
    a = e10_frames.row_key("bowl-diffuse", {"realtime.occlusion": "vct", "realtime.vct.resolution": 64}, (192, 192))
    b = e10_frames.row_key("bowl-diffuse", {"realtime.vct.resolution": 64, "realtime.occlusion": "vct"}, (192, 192))
    assert a == b == "bowl-diffuse occlusion=vct vct.resolution=64 192x192"
    assert e10_frames.row_key("bowl-diffuse", {}, (1920, 1080)) == "bowl-diffuse 1920x1080"


@pytest.mark.parametrize("text", ["1920", "0x1080", "1920x-1", "widexhigh", "1920x1080x3"])
def test_parse_size_refuses_what_is_not_two_positive_integers(text):
    with pytest.raises(argparse.ArgumentTypeError, match="--size"):
        e10_frames.parse_size(text)


def test_parse_size_reads_width_then_height():
    assert e10_frames.parse_size("1920x1080") == (1920, 1080)


def test_rows_are_e10s_fifty_at_its_size_first():
    # E10's FULL grid has 7 VCT settings, each with and without interreflection, after the direct row; the
    # ladder adds PRT on the two diffuse scenes and the light array on all three: 3 x 15 + 2 + 3 = 50
    rows = e10_frames.rows([])
    assert len(rows) == 50
    assert {size for *_, size in rows} == {(192, 192)}
    wide = e10_frames.rows([(1920, 1080)])
    assert len(wide) == 100
    assert [size for *_, size in wide] == [(192, 192)] * 50 + [(1920, 1080)] * 50
    # the same size twice is timed once
    assert len(e10_frames.rows([(192, 192)])) == 50


def test_rows_of_one_scene_and_an_unknown_scene():
    bowl = e10_frames.rows([], ["bowl-diffuse"])
    assert {name for name, *_ in bowl} == {"bowl-diffuse"} and len(bowl) == 17
    with pytest.raises(ValueError, match="sponza"):
        e10_frames.rows([], ["bowl-diffuse", "sponza"])


def smooth_image(n: int = 48) -> np.ndarray:
    """An image with no mirror symmetry: a flip of it is far from it."""
    y, x = np.mgrid[0:n, 0:n] / n
    return np.stack([0.2 + 0.8 * x, 0.3 + 0.5 * y * x, 0.1 + 0.9 * x**2], axis=-1).astype(np.float32)


def test_agreement_of_an_image_with_itself_and_with_its_mirror():
    scene = scenes.load("builtin:bowl-diffuse")
    img = smooth_image()
    mask = np.ones(img.shape[:2], bool)
    assert e10_frames.agreement(img, mask, img.copy(), mask, scene) == (metrics.PSNR_CAP, 0)
    # float16 storage, as the runs keep their images: far above the threshold a convention error falls under
    psnr16, _ = e10_frames.agreement(img.astype(np.float16), mask, img, mask, scene)
    assert psnr16 > 60.0
    # negative control: an image mirrored left to right, as one renderer off by a flip would give
    flipped, _ = e10_frames.agreement(img[:, ::-1], mask, img, mask, scene)
    assert flipped < e10_frames.AGREE_DB


def test_agreement_compares_displayed_pixels_that_both_cover_inside_the_eroded_mask():
    scene = scenes.load("builtin:bowl-diffuse")
    img = smooth_image()
    n = img.shape[0]
    gpu_mask = np.zeros((n, n), bool)
    gpu_mask[4:-4, 4:-4] = True
    cpu_mask = gpu_mask.copy()
    cpu_mask[10, 4:9] = False  # five pixels the CPU image does not cover
    other = img.copy()
    other[10, 4:9] = 50.0  # where only one covers: not compared, counted
    other[4, 20] = 50.0  # on the common mask's edge, which the one-pixel erosion takes away
    assert e10_frames.agreement(other, gpu_mask, img, cpu_mask, scene) == (metrics.PSNR_CAP, 5)
    # inside, twice the radiance: the PSNR of the displayed images, which differs from the linear values' PSNR
    other[20:30, 20:30] *= 2.0
    inside = np.zeros((n, n), bool)
    inside[5:-5, 5:-5] = True
    inside[10, 4:10] = False  # the five uncovered pixels and, by the cross's erosion, their row neighbour
    inside[9, 4:9] = False  # and the pixels above and below them
    inside[11, 4:9] = False
    shown = metrics.psnr(metrics.display(scene, other), metrics.display(scene, img), inside)
    got, _ = e10_frames.agreement(other, gpu_mask, img, cpu_mask, scene)
    assert got == pytest.approx(shown, abs=1e-9)
    assert abs(got - metrics.psnr(other, img, inside)) > 1.0


def write_run(folder: Path, gl: str, rows: list[tuple[dict, dict]], images: dict[str, np.ndarray]) -> None:
    """A run's folder as `measure` leaves it: rows of bowl-diffuse at 192 x 192 ({overrides}, {timings})."""
    folder.mkdir(parents=True)
    doc = {"gl": gl, "software_gl": False, "frames": 20, "warmup_frames": 3, "rows": []}
    for ov, timings in rows:
        setting = [ov["realtime.vct.resolution"], 1, 6] if ov else None
        doc["rows"].append({"key": e10_frames.row_key("bowl-diffuse", ov, (192, 192)), "scene": "bowl-diffuse",
                            "overrides": ov, "size": [192, 192],
                            "mode": "occlusion" if ov else "direct (paper)", "setting": setting,
                            "timings": timings})
    (folder / "frames.json").write_text(json.dumps(doc))
    np.savez_compressed(folder / "images.npz", **images)


def test_compare_sets_each_row_beside_the_cpu_run(tmp_path):
    vct = {"realtime.occlusion": "vct", "realtime.vct.resolution": 64, "realtime.vct.cascades": 1,
           "realtime.vct.diffuse_cones": 6}
    k_direct = e10_frames.row_key("bowl-diffuse", {}, (192, 192))
    k_vct = e10_frames.row_key("bowl-diffuse", vct, (192, 192))
    img = smooth_image(192)
    mask = np.ones((192, 192), bool)
    write_run(tmp_path / "gpu", "NVIDIA test",
              [({}, {"total": 0.5, "draw": 0.25}), (vct, {"total": 10.0, "draw": 4.25, "voxelize": 5.0})],
              {f"{k_direct}|rgb": img, f"{k_direct}|mask": mask, f"{k_vct}|rgb": img[:, ::-1],
               f"{k_vct}|mask": mask})
    # the CPU run has the direct row only
    write_run(tmp_path / "cpu", "llvmpipe test", [({}, {"total": 20.0, "draw": 10.0})],
              {f"{k_direct}|rgb": img, f"{k_direct}|mask": mask})
    lines = e10_frames.compare(e10_frames.load_pair(tmp_path / "gpu", tmp_path / "cpu"))
    table = [line for line in lines if line.startswith("| bowl-diffuse")]
    assert len(table) == 2
    direct_cells = [c.strip() for c in table[0].strip("|").split("|")]
    # GPU 0.5 ms, CPU 20 ms: 40 times; the same image on both: the PSNR cap, no pixel covered by one only
    assert direct_cells[4:] == ["0.50", "20.00", "40", "-", "-", f"{metrics.PSNR_CAP:.2f}", "0"]
    vct_cells = [c.strip() for c in table[1].strip("|").split("|")]
    # trace = its draw less the direct row's: 4.25 - 0.25; no CPU row, so no ratio and no image comparison
    assert vct_cells[3:] == ["64x1x6", "10.00", "-", "-", "5.00", "4.00", "-", "-"]
    assert lines[-1].startswith("Images: 1 rows compared") and "all at 40 dB or more" in lines[-1]


def test_compare_names_the_rows_whose_images_disagree(tmp_path):
    k = e10_frames.row_key("bowl-diffuse", {}, (192, 192))
    img = smooth_image(192)
    mask = np.ones((192, 192), bool)
    write_run(tmp_path / "gpu", "NVIDIA test", [({}, {"total": 0.5, "draw": 0.25})],
              {f"{k}|rgb": img[::-1], f"{k}|mask": mask})  # upside down
    write_run(tmp_path / "cpu", "llvmpipe test", [({}, {"total": 20.0, "draw": 10.0})],
              {f"{k}|rgb": img, f"{k}|mask": mask})
    last = e10_frames.compare(e10_frames.load_pair(tmp_path / "gpu", tmp_path / "cpu"))[-1]
    assert "1 under 40 dB: bowl-diffuse 192x192." in last


E10_HEADER = ("| scene | mode | resolution | cascades | cones | unbiased PSNR dB | frame ms | voxelize ms | mip ms "
              "| trace ms | voxel MiB | single 3D texture MiB |")


def test_e10_psnr_reads_the_row_table_of_the_e10_section_only():
    summary = "\n".join([
        "# suite", "", "## E9 other", "", "| cornell-open | occlusion | 32 | 1 | 6 | 99 | 1 | - | - | - | - | - |",
        "", "## E10 what interreflection costs", "", E10_HEADER, "|---" * 12 + "|",
        "| cornell-open | direct \\(paper\\) | \\- | \\- | \\- | 13\\.36 | 23\\.18 | \\- | \\- | \\- | \\- | \\- |",
        "| cornell-open | occlusion | 32 | 1 | 6 | 13\\.88 (floor) | 635\\.93 | 40 | 5 | 570 | 2\\.9 | 2\\.9 |",
        # the energy table that follows has ten columns: not a row of the row table
        "| cornell-open | 128x1x6 | 0\\.5952 | 0\\.1211 | 0\\.1675 | 0\\.1305 | 0\\.18 | 0\\.22 | 0\\.947 | 0\\.93 |",
        "", "## E11 next", "", "| bowl-diffuse | occlusion | 64 | 1 | 6 | 50 | 1 | - | - | - | - | - |"])
    assert e10_frames.e10_psnr(summary) == {("cornell-open", "direct (paper)", None): (13.36, False),
                                            ("cornell-open", "occlusion", (32, 1, 6)): (13.88, True)}


def test_every_row_timed_has_a_psnr_in_the_committed_e10_table():
    psnr = e10_frames.e10_psnr((ROOT / "reports" / "paper" / "summary.md").read_text())
    assert len(psnr) == 50
    for name, _, ov, _ in e10_frames.rows([]):
        # E10 names a row's mode from the techniques that ran, which are the overrides' here
        chosen = argparse.Namespace(techniques={k.removeprefix("realtime."): v for k, v in ov.items()})
        setting = e10_frames.e10.setting(argparse.Namespace(overrides=ov))
        assert (name, e10_frames.e10.mode(chosen), setting) in psnr


def test_the_figures_are_drawn_from_two_runs_and_pick_the_row_that_differs_most(tmp_path):
    vct = {"realtime.occlusion": "vct", "realtime.vct.resolution": 32, "realtime.vct.cascades": 1,
           "realtime.vct.diffuse_cones": 6}
    keys = [e10_frames.row_key("bowl-diffuse", ov, (192, 192)) for ov in ({}, vct)]
    img = smooth_image(192)
    mask = np.ones((192, 192), bool)
    masks = {f"{k}|mask": mask for k in keys}
    rows = [({}, {"total": 0.5, "draw": 0.25}), (vct, {"total": 10.0, "draw": 4.25, "voxelize": 5.0})]
    write_run(tmp_path / "gpu", "NVIDIA test", rows, {f"{keys[0]}|rgb": img, f"{keys[1]}|rgb": img[:, ::-1], **masks})
    write_run(tmp_path / "cpu", "llvmpipe test", rows, {f"{keys[0]}|rgb": img, f"{keys[1]}|rgb": img, **masks})
    pair = e10_frames.load_pair(tmp_path / "gpu", tmp_path / "cpu")
    worst = e10_frames.worst_rows(pair)
    assert list(worst) == ["bowl-diffuse"] and worst["bowl-diffuse"][1]["key"] == keys[1]
    e10_frames.plot_differences(pair, tmp_path / "diff.png")
    e10_frames.plot_ladder(tmp_path / "gpu", ROOT / "reports" / "paper" / "summary.md", tmp_path / "ladder.png")
    assert (tmp_path / "diff.png").stat().st_size > 10_000 and (tmp_path / "ladder.png").stat().st_size > 10_000


def test_compare_writes_the_table_it_prints(tmp_path, capsys):
    k = e10_frames.row_key("bowl-diffuse", {}, (192, 192))
    for run in ("gpu", "cpu"):
        write_run(tmp_path / run, run, [({}, {"total": 0.5, "draw": 0.25})], {})
    assert e10_frames.main(["compare", str(tmp_path / "gpu"), str(tmp_path / "cpu"),
                            "--markdown", str(tmp_path / "t.md")]) == 0
    printed = capsys.readouterr().out
    assert (tmp_path / "t.md").read_text() == printed and k.split()[0] in printed


@pytest.mark.parametrize("args, names", [
    (["measure", "--out", "{tmp}/run", "--scene", "sponza"], "sponza"),
    (["measure", "--out", "{tmp}/run", "--frames", "0"], "--frames 0"),
    (["compare", "{tmp}/nothing", "{tmp}/nothing"], "nothing: no frames.json"),
    (["ladder", "{tmp}/gpu", "--summary", "{tmp}/summary.md", "--out", "{tmp}/l.png"], "no E10 section"),
    (["compare", "{tmp}/gpu", "{tmp}/gpu", "--figure", "{tmp}/f.png"], "no row has images"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, args, names):
    write_run(tmp_path / "gpu", "NVIDIA test", [({}, {"total": 0.5, "draw": 0.25})], {})
    (tmp_path / "summary.md").write_text("# suite\n\n## E9 other\n")
    assert e10_frames.main([a.format(tmp=tmp_path) for a in args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("e10_frames: ") and names in err
    assert not (tmp_path / "run").exists()  # nothing rendered, nothing half written


@pytest.mark.gl
def test_measure_writes_each_row_with_its_timings_and_image(tmp_path, monkeypatch):
    # the direct row and one VCT row of one scene at 32 x 24 (E10's size, shrunk here), one timed frame
    vct = {"realtime.occlusion": "vct", "realtime.vct.resolution": 16, "realtime.vct.cascades": 1,
           "realtime.vct.diffuse_cones": 4}
    monkeypatch.setattr(e10_frames.e10, "configs", lambda settings, spec: [{}, vct])
    monkeypatch.setattr(e10_frames, "E10_SIZE", (32, 24))
    e10_frames.measure(tmp_path / "run", 1, 0, [(40, 30)], ["torus-phong"])
    doc, images = e10_frames.load(tmp_path / "run")
    assert [r["key"] for r in doc["rows"]] == [
        e10_frames.row_key("torus-phong", ov, size) for size in ((32, 24), (40, 30)) for ov in ({}, vct)]
    assert [r["mode"] for r in doc["rows"]] == ["direct (paper)", "occlusion"] * 2
    assert [r["size"] for r in doc["rows"]] == [[32, 24], [32, 24], [40, 30], [40, 30]]  # width x height
    assert doc["rows"][1]["setting"] == [16, 1, 4] and doc["rows"][0]["setting"] is None
    assert all(r["timings"]["total"] > 0 and r["nonfinite"] == 0 for r in doc["rows"])
    assert doc["gl_limits"]["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"] >= 2**27  # GL 4.3's minimum
    # images at E10's size only, as the render's (rows, columns) and with the object covered
    assert sorted(images) == sorted(f"{r['key']}|{part}" for r in doc["rows"][:2] for part in ("rgb", "mask"))
    first = doc["rows"][0]["key"]
    assert images[f"{first}|rgb"].shape == (24, 32, 3) and images[f"{first}|rgb"].dtype == np.float16
    assert 0 < images[f"{first}|mask"].sum() < 24 * 32
