"""`iblcheck gate --images MANIFEST` / `sweep --images MANIFEST`: another project's CI gating its own
renderer against a baseline, with images made by iblcheck itself (its real-time render as EXR)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import scenes
from experiments.cli import main as cli
from experiments.measure import comparison
from experiments.runs import image_manifest
from scenes import InputError
from scenes.storage.imageio import write_exr

SCENE = "builtin:sphere-diffuse"
TINY = ["camera.width=64", "camera.height=64", "reference.spp=64", "realtime.timing_frames=2",
        "realtime.warmup_frames=1"]
SETS = [x for kv in TINY for x in ("--set", kv)]


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(autouse=True)
def _cache_env(cache, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(cache))


def manifest(folder: Path, image: str, label: str = "mine") -> Path:
    path = folder / "images.toml"
    path.write_text(f'[[images]]\nscene = "{SCENE}"\nimage = "{image}"\nlabel = "{label}"\n')
    return path


@pytest.mark.parametrize("text,where", [
    ('[[images]]\nscene = "builtin:sphere-diffuse"\n', "images[0].image"),
    ('[[images]]\nscene = "builtin:sphere-diffuse"\nimage = "a.png"\n', "images[0].encoding"),
    ('[[images]]\nscene = "builtin:sphere-diffuse"\nimage = "a.png"\nencoding = "srgb"\n', "images[0].tonemap"),
    ('[[images]]\nscene = "builtin:sphere-diffuse"\nimage = "a.exr"\nexposure = -1\n', "images[0].exposure"),
    ('[[images]]\nscene = "builtin:sphere-diffuse"\nimage = "a.png"\nencoding = "srgb"\ntonemap = "scene"\n'
     'exposure = 2\n', "images[0].exposure"),
    ('[[images]]\nscene = "builtin:sphere-diffuse"\nimage = "a.exr"\ncolour = 1\n', "images[0].colour"),
    ('[[images]]\nscene = "builtin:sphere-diffuse"\nimage = "a.exr"\n[[images]]\nscene = "builtin:sphere-diffuse"\n'
     'image = "b/a.exr"\n', "images[1].label"),
    ('images = 3\n', "images:"),
    ('not toml [', "not valid TOML"),
])
def test_manifest_errors_name_file_index_and_key(tmp_path, text, where):
    path = tmp_path / "m.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=where.replace("[", r"\[").replace("]", r"\]")) as info:
        image_manifest.read_manifest(path)
    assert str(path) in str(info.value)


def test_json_manifest_and_relative_paths(tmp_path):
    path = tmp_path / "m.json"
    path.write_text(json.dumps({"images": [{"scene": "builtin:sphere-diffuse", "image": "out/x.png",
                                            "encoding": "srgb", "tonemap": "agx", "exposure": 2}]}))
    (e,) = image_manifest.read_manifest(path)
    assert e.image == tmp_path / "out/x.png" and e.label == "x" and e.key == "builtin:sphere-diffuse#x"
    assert (e.encoding, e.tonemap, e.exposure) == ("srgb", "agx", 2.0)


@pytest.mark.gl
@pytest.mark.mitsuba
def test_ci_gates_its_renderer_against_a_baseline(tmp_path, capsys, cache):
    scene = scenes.load(SCENE).with_overrides(dict(kv.split("=") for kv in TINY))
    rgb = comparison.render_realtime(scene).rgb
    (tmp_path / "ok").mkdir()
    (tmp_path / "dark").mkdir()
    write_exr(tmp_path / "ok" / "frame.exr", rgb)
    write_exr(tmp_path / "dark" / "frame.exr", rgb * 0.7)
    base = tmp_path / "baseline.json"
    assert cli.main(["gate", "--images", str(manifest(tmp_path / "ok", "frame.exr")), "--write-baseline", str(base),
                     *SETS]) == 0
    rec = json.loads(base.read_text())["scenes"]
    assert list(rec) == [f"{SCENE}#mine"]
    capsys.readouterr()
    junit = tmp_path / "gate.xml"
    assert cli.main(["gate", "--images", str(manifest(tmp_path / "ok", "frame.exr")), "--baseline", str(base),
                     "--junit", str(junit), *SETS]) == 0
    assert "1 passed" in capsys.readouterr().out and "ImageQuality" not in junit.read_text()
    code = cli.main(["gate", "--images", str(manifest(tmp_path / "dark", "frame.exr")), "--baseline", str(base),
                     "--junit", str(junit), *SETS])
    out = capsys.readouterr().out
    print(out)
    assert code == 1 and "psnr fell from the baseline" in out and "ImageQuality" in junit.read_text()
    assert cli.main(["gate", "--images", str(manifest(tmp_path / "ok", "gone.exr")), "--baseline", str(base),
                     *SETS]) == 2
    err = capsys.readouterr().err
    assert "gone.exr" in err and "images[0].image" in err
    # the sweep: one row per entry, its technique naming the engine; a rerun adds none
    out_dir = tmp_path / "sweep"
    m = manifest(tmp_path / "ok", "frame.exr")
    assert cli.main(["sweep", "--images", str(m), "--out", str(out_dir), *SETS]) == 0
    assert cli.main(["sweep", "--images", str(m), "--out", str(out_dir), *SETS]) == 0
    rows = [json.loads(line) for line in (out_dir / "results.jsonl").read_text().splitlines()]
    assert len(rows) == 1 and rows[0]["techniques"]["renderer"] == "image" and rows[0]["techniques"]["label"] == "mine"
    assert rows[0]["psnr"] == pytest.approx(rec[f"{SCENE}#mine"]["metrics"]["psnr"], abs=0)
    assert np.isfinite(rows[0]["psnr"])
    summary = (out_dir / "summary.md").read_text()
    assert "| image mine | \\- |" in summary and "None" not in summary  # named by its label, no cube face


@pytest.mark.parametrize("flag, value", [("--face-sizes", "8,16"), ("--axis", "realtime.glossy=box"),
                                         ("--workers", "2")])
def test_sweep_options_are_refused_with_images(tmp_path, capsys, flag, value):
    manifest = tmp_path / "m.toml"
    manifest.write_text('[[images]]\nscene = "builtin:sphere-diffuse"\nimage = "x.exr"\n')
    assert cli.main(["sweep", "--images", str(manifest), flag, value, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {flag}") and "not with --images" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "o").exists()
