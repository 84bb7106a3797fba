"""Helpers for the hard-case tests: running the CLI in a subprocess, tiny scenes on disk."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

import scenes
from tests.helpers import sphere_scene_text

ROOT = Path(__file__).resolve().parents[2]

def write_tiny(folder: Path, env: str = "builtin:uffizi", shape: str = "sphere", size: int = 16,
               material: str = '{ type = "blend" }', name: str = "tiny", extra: str = "") -> Path:
    path = folder / f"{name}.toml"
    tables = "[realtime]\ntiming_frames = 1\nwarmup_frames = 0\n[reference]\nspp = 8"
    path.write_text(sphere_scene_text(name, f'map = "{env}"', material, size, shape=shape, tables=tables) + extra)
    return path


def run_cli(*args: str, cache: Path | None = None) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    if cache is not None:
        env["IBLCHECK_CACHE"] = str(cache)
    return subprocess.run([sys.executable, "-m", "experiments.cli.main", *args], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=600)


def one_error_line(out: subprocess.CompletedProcess) -> str:
    """The single `error:` line of a refused run (exit 2, no traceback)."""
    assert out.returncode == 2, (out.returncode, out.stdout, out.stderr)
    lines = [line for line in out.stderr.strip().splitlines() if not line.startswith("warning:")]
    assert len(lines) == 1 and lines[0].startswith("error: "), out.stderr
    assert "Traceback" not in out.stderr
    return lines[0]


def write_env(path: Path, rgb: np.ndarray) -> Path:
    from scenes.storage import imageio

    if path.suffix == ".exr":
        imageio.write_exr(path, rgb.astype(np.float32))
    elif path.suffix == ".pfm":
        imageio.write_pfm(path, rgb.astype(np.float32))
    else:
        imageio.write_hdr(path, rgb.astype(np.float32))
    return path


def small_scene(name: str, **overrides):
    """Scene `name` (a builtin or a file) at 24 x 24, one untimed frame, 8 spp, with `overrides`."""
    base = {"camera.width": 24, "camera.height": 24, "realtime.timing_frames": 1, "realtime.warmup_frames": 0,
            "reference.spp": 8}
    return scenes.load(name).with_overrides({**base, **overrides})
