"""The README's "Bring your own renderer" path, command by command: `iblcheck export`, three.js through
engines/web/render.mjs, `iblcheck compare --image`, `iblcheck diagnose`. A Lambertian sphere (the export's
`diffuse` is exactly Lambert through KHR_materials_specular) under a smooth probe: three.js' irradiance from
its PMREM is close to the path tracer's, so the score must clear 30 dB; the same image against the probe turned
a quarter turn must lose more than 5 dB (the control), and the diagnosis must find nothing on it."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from experiments.cli.main import main
from tests.engines.test_web_engines import WEB, _web_missing

SETS = ["--set", "camera.width=48", "--set", "camera.height=48", "--set", "reference.spp=64"]
SCENE = "builtin:sphere-diffuse"

pytestmark = [pytest.mark.browser, pytest.mark.mitsuba, pytest.mark.slow,
              pytest.mark.skipif(_web_missing() is not None, reason=str(_web_missing()))]


def _compare(image: Path, capsys, *extra: str) -> dict:
    assert main(["compare", SCENE, *SETS, *extra, "--image", str(image), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_export_then_three_js_then_compare_and_diagnose(tmp_path, capsys):
    folder, image = tmp_path / "export", tmp_path / "three.exr"
    assert main(["export", SCENE, str(folder), *SETS]) == 0
    capsys.readouterr()
    done = subprocess.run(["node", str(WEB / "render.mjs"), "--engine", "threejs", "--sidecar",
                           str(folder / "iblcheck-export.json"), "--output", str(image), "--timings",
                           str(tmp_path / "three.timings.json")], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    scored = _compare(image, capsys)
    assert scored["psnr"] > 30.0, scored
    assert scored["realtime_ms"]["total"] > 0  # three.js' frame time, read from the timings file beside the image
    turned = _compare(image, capsys, "--set", "environment.rotation_deg=90")
    assert turned["psnr"] < scored["psnr"] - 5.0, (scored["psnr"], turned["psnr"])
    assert main(["diagnose", SCENE, *SETS, "--image", str(image), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["mistakes"] == []
