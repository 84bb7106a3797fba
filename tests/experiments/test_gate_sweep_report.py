"""gate, sweep and report through the CLI, on tiny images (24 x 24, 16 spp, 2 timed frames)."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

import scenes
from experiments.cli import main as cli
from experiments.measure.results import ResultStore
from experiments.runs import sweep

pytestmark = [pytest.mark.gl, pytest.mark.mitsuba]
ROOT = Path(__file__).resolve().parents[2]
TINY = ["camera.width=24", "camera.height=24", "reference.spp=16", "realtime.timing_frames=2",
        "realtime.warmup_frames=1"]


def sets(*extra: str) -> list[str]:
    out = []
    for kv in (*TINY, *extra):
        out += ["--set", kv]
    return out


@pytest.fixture(autouse=True)
def cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


def test_gate_pass_fail_and_junit(tmp_path, capsys):
    junit = tmp_path / "gate.xml"
    code = cli.main(["gate", "builtin:sphere-diffuse", "builtin:sphere-blend", "--min-psnr", "10",
                     "--junit", str(junit), *sets()])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "2 passed, 0 failed" in out
    suite = ET.parse(junit).getroot().find("testsuite")
    assert [c.get("name") for c in suite.findall("testcase")] == ["sphere-diffuse", "sphere-blend"]
    assert suite.get("failures") == "0"

    code = cli.main(["gate", "builtin:sphere-diffuse", "--min-psnr", "99", "--junit", str(junit), *sets()])
    out = capsys.readouterr().out
    assert code == 1 and "FAIL" in out
    case = ET.parse(junit).getroot().find("testsuite/testcase")
    assert case.get("name") == "sphere-diffuse" and "psnr" in case.find("failure").get("message")


def test_gate_uses_the_scenes_gate_table(tmp_path, capsys):
    text = (ROOT / "scenes/data/scenes/sphere-diffuse.toml").read_text() + "\n[gate]\nmin_ssim = 0.999999\n"
    path = tmp_path / "strict.toml"
    path.write_text(text.replace("builtin:", "builtin:"))
    assert cli.main(["gate", str(path), *sets()]) == 1
    assert "ssim" in capsys.readouterr().out


@pytest.mark.parametrize("bad", ["[camera\nfov_deg = 30", '[camera]\nfov_deg = "wide"', "[camera]\nzoom = 2"])
def test_gate_malformed_scene_exits_2_with_one_error_line(tmp_path, bad):
    path = tmp_path / "bad.toml"
    path.write_text(bad)
    out = subprocess.run([sys.executable, "-m", "experiments.cli.main", "gate", str(path), "--min-psnr", "20"],
                         capture_output=True, text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "bad.toml" in lines[0], out.stderr


def test_gate_without_thresholds_is_a_usage_error(capsys):
    assert cli.main(["gate", "builtin:sphere-diffuse", *sets()]) == 2
    assert "no gate thresholds" in capsys.readouterr().err


def test_sweep_skips_axes_that_cannot_matter():
    axes = sweep.Axes(face_sizes=[8, 16], lod_biases=[0.0, 1.0, 2.0], exponents=[10.0, 100.0], f0s=[0.04, 0.5])
    diffuse = list(sweep.configurations(scenes.load("builtin:sphere-diffuse"), axes))
    phong = list(sweep.configurations(scenes.load("builtin:sphere-phong"), axes))
    blend = list(sweep.configurations(scenes.load("builtin:sphere-blend"), axes))
    assert len(diffuse) == 2 and not any("realtime.lod_bias" in c for c in diffuse)
    assert len(phong) == 2 * 2 * 3 and not any("objects.*.material.f0" in c for c in phong)
    assert len(blend) == 2 * 2 * 2 * 3


def _sweep_cmd(out: Path) -> list[str]:
    return [sys.executable, "-m", "experiments.cli.main", "sweep", "builtin:sphere-phong", "--face-sizes", "8,16,32",
            "--lod-biases", "0,1,2", "--out", str(out), *sets()]


def test_sweep_killed_midway_resumes_with_every_row_once(tmp_path):
    out = tmp_path / "sweep"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(_sweep_cmd(out), cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    results = out / sweep.RESULTS
    deadline = time.time() + 240
    while time.time() < deadline and proc.poll() is None:
        if results.exists() and len(results.read_text().splitlines()) >= 2:
            break
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    store = ResultStore(results)
    first = store.read()
    assert 2 <= len(first) < 9, "the kill should land mid-way"
    # a half-written line, as a kill during a write leaves it
    with open(results, "a") as f:
        f.write('{"id": "half-writ')
    done = subprocess.run(_sweep_cmd(out), cwd=ROOT, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rows = store.read()
    ids = [r.id for r in rows]
    assert len(ids) == 9 and len(set(ids)) == 9
    assert {(r.face_size, r.lod_bias) for r in rows} == {(s, b) for s in (8, 16, 32) for b in (0.0, 1.0, 2.0)}
    assert [r.id for r in rows[: len(first)]] == [r.id for r in first]  # nothing lost
    for line in results.read_text().splitlines():
        json.loads(line)


@pytest.fixture(scope="module")
def small_report(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("report")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "IBLCHECK_CACHE": str(tmp_path_factory.getbasetemp() / "cache")}
    cmd = [sys.executable, "-m", "experiments.cli.main", "sweep", "builtin:sphere-blend", "builtin:sphere-diffuse",
           "--face-sizes", "8,32", "--lod-biases", "0,2", "--out", str(out), *sets()]
    done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return out


def test_report_references_every_image_it_lists(small_report):
    html = (small_report / "index.html").read_text()
    srcs = re.findall(r'src="([^"]+)"', html)
    files = [s for s in srcs if not s.startswith("data:")]
    assert files.pop() == "viewer/viewer.js"  # the page's one script, last
    assert len(files) == 4 * 6  # 6 rows (4 blend + 2 diffuse), 4 pictures each
    for s in files:
        assert (small_report / s).is_file(), s
    assert sum(s.startswith("data:image/png;base64,") for s in srcs) == 3  # the three plots, inline
    for name in ("psnr_ssim_vs_lod_bias.png", "psnr_vs_frame_time.png", "time_vs_face_size.png"):
        assert (small_report / "figures" / name).is_file()
    assert (small_report / "summary.md").read_text().count("| sphere-") == 2


def test_report_regenerates_from_results(small_report):
    (small_report / "index.html").unlink()
    assert cli.main(["report", str(small_report)]) == 0
    assert (small_report / "index.html").is_file()


def test_report_of_no_rows_leaves_no_figure_of_the_rows_that_were(small_report, tmp_path):
    emptied = tmp_path / "emptied"
    shutil.copytree(small_report, emptied)
    (emptied / "results.jsonl").write_text("")
    assert cli.main(["report", str(emptied)]) == 0
    for name in ("psnr_ssim_vs_lod_bias.png", "psnr_vs_frame_time.png", "time_vs_face_size.png"):
        assert (small_report / "figures" / name).is_file()  # the control: the full report has them
        assert not (emptied / "figures" / name).exists(), name
    assert "data:image/png;base64," not in (emptied / "index.html").read_text()


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


def test_report_opens_in_headless_chromium_without_console_errors(small_report, tmp_path):
    browser = _chromium()
    if browser is None:
        pytest.skip("no chromium: `make test` installs Debian's chromium when it runs as root with apt-get; "
                    "here it could not")
    out = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--enable-logging=stderr", "--v=0",
                          f"--user-data-dir={tmp_path / 'profile'}", "--dump-dom",
                          (small_report / "index.html").as_uri()], capture_output=True, text=True, timeout=120)
    assert "</table>" in out.stdout, out.stderr[-2000:]
    console = [line for line in out.stderr.splitlines() if "CONSOLE" in line or "Uncaught" in line]
    assert not console, console
    failed = [line for line in out.stderr.splitlines() if "ERR_FILE_NOT_FOUND" in line]
    assert not failed, failed
