"""The GPU run's packing and device steps (benchmarks/gpu/), on this machine: no GPU is needed to check
that what pack.py cuts into parts is what device.sh reassembles, checks and installs."""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
DEVICE = ROOT / "benchmarks" / "gpu" / "device.sh"
_spec = importlib.util.spec_from_file_location("gpu_pack", ROOT / "benchmarks" / "gpu" / "pack.py")
pack = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(pack)


def tiny_wheel(folder: Path) -> Path:
    """A pure-Python wheel of one module `tinygpu` whose `VALUE` is 42."""
    path = folder / "tinygpu-0.1-py3-none-any.whl"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("tinygpu.py", "VALUE = 42\n")
        z.writestr("tinygpu-0.1.dist-info/METADATA", "Metadata-Version: 2.1\nName: tinygpu\nVersion: 0.1\n")
        z.writestr("tinygpu-0.1.dist-info/WHEEL",
                   "Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: true\nTag: py3-none-any\n")
        z.writestr("tinygpu-0.1.dist-info/RECORD", "")
    return path


def packed(tmp: Path, part_bytes: int) -> Path:
    """A fake checkout with .gpu/ as pack.py leaves it (a payload of one tiny wheel and filler)."""
    payload = tmp / "payload"
    (payload / "wheels").mkdir(parents=True)
    tiny_wheel(payload / "wheels")
    (payload / "filler.bin").write_bytes(np.random.default_rng(0).bytes(5000))  # several parts' worth
    tar = tmp / "payload.tar"
    with tarfile.open(tar, "w") as t:
        t.add(payload, arcname=".")
    repo = tmp / "repo"
    gpu = repo / ".gpu"
    parts = pack.split(tar, gpu, part_bytes)
    manifest = {"sha256": hashlib.sha256(tar.read_bytes()).hexdigest(), "parts": [str(p) for p in parts]}
    (gpu / "manifest.json").write_text(json.dumps(manifest))
    return repo


def device(repo: Path, home: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHON": sys.executable, "IBLCHECK_GPU_HOME": str(home), "IBLCHECK_GPU_SKIP_GL": "1"}
    return subprocess.run(["bash", str(DEVICE), *args], cwd=repo, env=env, capture_output=True, text=True)


def test_split_parts_concatenate_to_the_file(tmp_path):
    data = np.random.default_rng(1).bytes(10_001)
    (tmp_path / "f").write_bytes(data)
    parts = pack.split(tmp_path / "f", tmp_path / "out", 4096)
    assert [p.stat().st_size for p in parts] == [4096, 4096, 1809]
    assert b"".join(p.read_bytes() for p in parts) == data


def test_wheel_project_names_are_canonical():
    assert pack.wheel_project(Path("flip_evaluator-1.7-cp312-cp312-manylinux_2_17_x86_64.whl")) == "flip-evaluator"
    assert pack.canonical("OpenEXR") == "openexr"
    present = pack.device_packages()
    assert {"numpy", "scipy", "scikit-image", "jinja2"} <= present
    assert not {"mitsuba", "moderngl", "drjit", "openexr"} & present  # what the run must carry


def test_device_steps_reassemble_check_and_install(tmp_path):
    repo = packed(tmp_path, 2048)
    n = len(list((repo / ".gpu").glob("part-*")))
    assert n >= 3
    home = tmp_path / "home"
    for i in range(n):
        assert device(repo, home, "receive", f"{i:02d}").returncode == 0
    done = device(repo, home, "install")
    assert done.returncode == 0, done.stderr
    found = subprocess.run([sys.executable, "-c", "import tinygpu; print(tinygpu.VALUE)"],
                           env={**os.environ, "PYTHONPATH": str(home / "site")}, capture_output=True, text=True)
    assert found.stdout.strip() == "42"


def test_device_refuses_parts_out_of_order(tmp_path):
    repo = packed(tmp_path, 2048)
    home = tmp_path / "home"
    assert device(repo, home, "receive", "00").returncode == 0
    assert device(repo, home, "receive", "02").returncode == 0  # part 01 skipped
    done = device(repo, home, "install")
    assert done.returncode == 2 and "checksum" in done.stderr
    assert not (home / "site").exists() or not any((home / "site").iterdir())


def test_device_refuses_a_part_that_was_not_carried(tmp_path):
    repo = packed(tmp_path, 2048)
    done = device(repo, tmp_path / "home", "receive", "99")
    assert done.returncode == 2 and "part-99" in done.stderr


@pytest.mark.parametrize("args", [[], ["frobnicate"]])
def test_device_usage(tmp_path, args):
    done = device(tmp_path, tmp_path / "home", *args)
    assert done.returncode == 2 and "usage" in done.stderr


def test_e10_frames_imports_nothing_the_realtime_only_payload_leaves_out_when_loaded():
    # `pack.py --realtime-only` carries REALTIME_NEEDED alone; e10_frames.py, which runs on it, must import
    # none of the rest (a module-level `import mitsuba` anywhere on its path would fail on the GPU machine)
    left_out = sorted({pack.canonical(n) for n in pack.NEEDED} - {pack.canonical(n) for n in pack.REALTIME_NEEDED})
    assert {"mitsuba", "drjit", "dask"} <= set(left_out)
    code = ("import importlib.util, sys; from importlib import metadata\n"
            "s = importlib.util.spec_from_file_location('e10_frames', 'benchmarks/gpu/e10_frames.py')\n"
            "m = importlib.util.module_from_spec(s); sys.modules[s.name] = m; s.loader.exec_module(m)\n"
            "dists = metadata.packages_distributions()\n"
            "print(' '.join(sorted({d for m in sys.modules for d in dists.get(m.split('.')[0], [])})))")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    imported = {pack.canonical(d) for d in done.stdout.split()}
    assert "moderngl" in imported  # the control: the check sees what the script does import
    assert not imported & set(left_out), imported & set(left_out)


@pytest.mark.gl
def test_device_script_step_runs_a_script_with_the_installed_wheels(tmp_path):
    repo = packed(tmp_path, 1 << 20)
    home = tmp_path / "home"
    assert device(repo, home, "receive", "00").returncode == 0
    assert device(repo, home, "install").returncode == 0
    script = tmp_path / "probe.py"
    script.write_text("import sys, tinygpu; print('value', tinygpu.VALUE, sys.argv[1:])\n")
    env = {**os.environ, "PYTHON": sys.executable, "IBLCHECK_GPU_HOME": str(home)}
    done = subprocess.run(["bash", str(DEVICE), "script", str(script), "a", "b"], cwd=ROOT, env=env,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "OpenGL renderer:" in done.stdout  # which GL the rows will come from, printed first
    assert "value 42 ['a', 'b']" in done.stdout
    missing = subprocess.run(["bash", str(DEVICE), "script", "no/such.py"], cwd=ROOT, env=env,
                             capture_output=True, text=True)
    assert missing.returncode == 2 and "no/such.py" in missing.stderr
    # a module, as pytest runs there: the installed wheel is found by `python -m` as well
    module = subprocess.run(["bash", str(DEVICE), "script", "-m", "tinygpu"], cwd=ROOT, env=env,
                            capture_output=True, text=True)
    assert module.returncode == 0, module.stderr
    no_module = subprocess.run(["bash", str(DEVICE), "script", "-m"], cwd=ROOT, env=env, capture_output=True,
                               text=True)
    assert no_module.returncode == 2 and "usage" in no_module.stderr
