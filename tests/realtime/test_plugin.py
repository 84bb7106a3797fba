"""A technique from another installed package: examples/technique-plugin (`realtime.diffuse =
"hemisphere"`) installed into a scratch folder and run through the CLI in a subprocess
(PYTHONPATH = that folder and the repository), like a user's `pip install` would.

The installation is `pip install --target` of a scratch copy, offline (no index, no build isolation:
the virtual environment's setuptools and wheel build it), so what the example's pyproject.toml ships
(its GLSL as package data, its entry point in `iblcheck.techniques`) is what the tests load.

Broken plugins (an import error, a wrong declaration, GLSL that does not compile) must give one line
naming the package, exit 2 or 3, no traceback, and leave the builtins working in the same environment.
"""

from __future__ import annotations

import importlib
import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "technique-plugin"
PACKAGE = "iblcheck_hemisphere"
DIST = "iblcheck-hemisphere"
SMALL = ["--set", "camera.width=48", "--set", "camera.height=48", "--set", "realtime.timing_frames=1",
         "--set", "realtime.warmup_frames=0"]


def install(src: Path, target: Path) -> Path:
    """`pip install --target` of the plugin at `src` (a scratch copy: pip builds in the source folder),
    offline: no index and no build isolation, the virtual environment's setuptools and wheel build it.
    Returns `target`."""
    build = target.parent / f"{target.name}-src"
    shutil.copytree(src, build, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info", "build"))
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-index",
                    "--no-build-isolation", "--target", str(target), str(build)], check=True, capture_output=True)
    return target


def pythonpath(*folders: Path) -> str:
    """The folders first, then the environment's own PYTHONPATH (a machine whose packages are installed into a
    folder, like the GPU machine's, finds them there)."""
    own = [os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else []
    return os.pathsep.join([*map(str, folders), *own])


def iblcheck(site: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": pythonpath(site, ROOT)}
    return subprocess.run([sys.executable, "-m", "experiments.cli.main", *args], capture_output=True, text=True,
                          env=env, cwd=cwd, timeout=600)


def broken_copy(tmp_path: Path, edit) -> Path:
    """A copy of the example with one file edited: edit(package folder)."""
    src = tmp_path / "src"
    shutil.copytree(EXAMPLE, src, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info", "build"))
    edit(src / PACKAGE)
    return install(src, tmp_path / "site")


def builtin_count() -> int:
    """The declarations the project's own entry points name, read from pyproject.toml (not the registry)."""
    entries = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]["iblcheck.techniques"]
    total = 0
    for target in entries.values():
        module, attr = target.split(":")
        total += len(getattr(importlib.import_module(module), attr))
    return total


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    return install(EXAMPLE, tmp_path_factory.mktemp("site"))


def test_the_example_registers_beside_the_builtins(site, tmp_path):
    code = ("from scenes.model import technique_registry as r; import json, sys; "
            "print(json.dumps([[d.effect, d.name, d.distribution, d.builtin, list(d.ladder)] "
            "for d in r.declarations()])); print('moderngl' in sys.modules)")
    env = {**os.environ, "PYTHONPATH": pythonpath(site, ROOT)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path,
                         check=True).stdout.splitlines()
    decls = json.loads(out[0])
    assert decls[-1] == ["diffuse", "hemisphere", DIST, False, [{"realtime.diffuse": "hemisphere"}]]
    assert all(d[3] for d in decls[:-1]) and len(decls) == builtin_count() + 1  # the builtins first
    assert out[1] == "False"  # loading every declaration imports no OpenGL


def hemisphere_expectation(scene) -> tuple[np.ndarray, np.ndarray]:
    """The image hemisphere lighting gives the unit diffuse sphere, by hand: each pixel's ray meets the
    sphere at p (|p| = 1, so n = p), and L = kd / pi E(n) = kd [(1 + n.y) / 2 L_s + (1 - n.y) / 2 L_g],
    with L_s, L_g the environment's upper and lower means over the map's rows, each row weighted by
    its band's solid angle (the integral of sin(theta) over the band)."""
    env = scene.environment.radiance().astype(np.float64)
    h = env.shape[0]
    theta = np.pi * np.arange(h) / (h - 1)
    edges = np.clip(np.stack([theta - np.pi / (2 * (h - 1)), theta + np.pi / (2 * (h - 1))]), 0, np.pi)
    band = np.cos(edges[0]) - np.cos(edges[1])  # the band's solid angle / (2 pi)
    row_mean = env.mean(axis=1)
    upper = np.where(np.cos(theta) > 1e-12, 1.0, np.where(np.abs(np.cos(theta)) <= 1e-12, 0.5, 0.0)) * band
    lower = band - upper
    sky, ground = upper @ row_mean / upper.sum(), lower @ row_mean / lower.sum()
    rays = scene.camera.pixel_rays()  # (H, W, 3) unit directions from camera.origin
    o = np.asarray(scene.camera.origin, dtype=np.float64)
    b = rays @ o
    disc = b * b - (o @ o - 1.0)
    hit = disc > 0
    t = -b - np.sqrt(np.where(hit, disc, 0.0))
    n = o + t[..., None] * rays
    up = 0.5 + 0.5 * n[..., 1:2]
    kd = np.asarray(scene.objects[0].material.kd)
    return kd * (up * sky + (1 - up) * ground), hit


@pytest.mark.gl
def test_render_matches_hemisphere_lighting_by_hand(site, tmp_path):
    import scenes
    from scenes.storage.imageio import read_exr

    r = iblcheck(site, "render", "builtin:sphere-diffuse", "--set", "realtime.diffuse=hemisphere", *SMALL,
                 "-o", str(tmp_path / "h.exr"), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["techniques"]["hemisphere"] == {"ground_scale": 1.0}
    image = read_exr(tmp_path / "h.exr")[..., :3].astype(np.float64)
    scene = scenes.load("builtin:sphere-diffuse").with_overrides({"camera.width": 48, "camera.height": 48})
    want, hit = hemisphere_expectation(scene)
    inner = hit & (np.abs(np.roll(hit, 1, 0) & np.roll(hit, -1, 0) & np.roll(hit, 1, 1) & np.roll(hit, -1, 1)))
    rel = np.abs(image[inner] - want[inner]) / want[inner].max()
    assert rel.max() < 0.01, rel.max()  # the tessellated sphere's interpolated normals: < 1 %
    # negative control: sky and ground swapped (the map upside down) is far from the image
    swapped = want[::-1, :, :]
    flipped = np.abs(image[inner] - swapped[inner]) / want[inner].max()
    assert flipped.max() > 0.05


@pytest.mark.gl
@pytest.mark.mitsuba
@pytest.mark.slow
def test_compare_runs_the_plugin(site, tmp_path):
    r = iblcheck(site, "compare", "builtin:sphere-diffuse", "--set", "realtime.diffuse=hemisphere",
                 "--set", "reference.spp=4", *SMALL, "--json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert "hemisphere" in out["realtime_ms"]  # the plugin's own timing key: it ran
    assert out["psnr"] > 10 and out["unsimulated_effects"] == []


@pytest.mark.gl
@pytest.mark.mitsuba
@pytest.mark.slow
def test_sweep_technique_axes_includes_the_plugin(site, tmp_path):
    r = iblcheck(site, "sweep", "builtin:sphere-diffuse", "--technique-axes", "--face-sizes", "16",
                 "--lod-biases", "0", *SMALL, "--set", "reference.spp=4", "--out", str(tmp_path / "s"),
                 cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    rows = [json.loads(line) for f in (tmp_path / "s").rglob("*.jsonl") for line in f.read_text().splitlines()]
    diffuse = [row["techniques"]["diffuse"] for row in rows]
    assert "hemisphere" in diffuse and "sh" in diffuse
    grounds = {row["techniques"]["hemisphere"]["ground_scale"] for row in rows if "hemisphere" in row["techniques"]}
    assert grounds == {0.0, 1.0}  # its declared axis


def _import_error(pkg: Path) -> None:
    text = (pkg / "declaration.py").read_text()
    (pkg / "declaration.py").write_text(text.replace("from dataclasses import", "import iblcheck_no_such_module\n"
                                                     "from dataclasses import", 1))


def _bad_declaration(pkg: Path) -> None:
    text = (pkg / "declaration.py").read_text()
    (pkg / "declaration.py").write_text(text.replace('simulates=frozenset({"diffuse"})', 'simulates="diffuse"'))


def _bad_glsl(pkg: Path) -> None:
    text = (pkg / "diffuse_hemisphere.glsl").read_text()
    (pkg / "diffuse_hemisphere.glsl").write_text(text.replace("return PI *", "return PI **"))


@pytest.mark.gl
@pytest.mark.parametrize(("edit", "code", "says"), [
    (_import_error, 3, "cannot be imported: ModuleNotFoundError"),
    (_bad_declaration, 2, "simulates must be a non-empty frozenset"),
    (_bad_glsl, 3, "its GLSL does not compile"),
], ids=["import-error", "bad-declaration", "bad-glsl"])
def test_a_broken_plugin_is_one_line_and_the_builtins_still_work(tmp_path, edit, code, says):
    site = broken_copy(tmp_path, edit)
    r = iblcheck(site, "render", "builtin:sphere-diffuse", "--set", "realtime.diffuse=hemisphere", *SMALL,
                 "-o", str(tmp_path / "h.exr"), cwd=tmp_path)
    assert r.returncode == code, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert f"'{DIST}'" in lines[0] and says in lines[0], lines[0]
    ok = iblcheck(site, "render", "builtin:sphere-diffuse", *SMALL, "-o", str(tmp_path / "b.exr"), cwd=tmp_path)
    assert ok.returncode == 0 and not ok.stderr.strip(), ok.stderr


def test_the_e7_ladder_takes_the_plugin_like_a_builtin(site, tmp_path):
    """E7 (experiments/paper/e07_accuracy_time_ladder.py) lists the plugin's ladder point on the scene of its
    effect, after the builtin points, which stay as they are without the plugin (their row ids)."""
    code = ("import json; from experiments.paper import e07_accuracy_time_ladder as e7; p = e7.plugin_points(); "
            "print(json.dumps([e7.configs_for(label, e7.QUICK, p) for label, _, _ in e7.scene_list()]))")
    def configs(path: str) -> list:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path,
                             env={**os.environ, "PYTHONPATH": path})
        return json.loads(out.stdout)

    with_plugin, without = configs(pythonpath(site, ROOT)), configs(pythonpath(ROOT))
    assert with_plugin[0] == without[0] + [{"realtime.diffuse": "hemisphere"}]  # sphere-diffuse
    assert with_plugin[1:] == without[1:]  # a diffuse technique adds nothing to the glossy scenes


@pytest.mark.slow
@pytest.mark.mitsuba
def test_an_e7_row_of_the_plugin_is_measured(site, tmp_path):
    """One E7 row of the plugin, through the row runner every experiment uses (experiments.paper.context)."""
    code = ("import json; from pathlib import Path; from experiments.paper.context import Common, Context; "
            "c = Context(Path('out'), Common(size=32, spp=16, frames=1), lambda: None); "
            "r = c.row('builtin:sphere-diffuse', {'realtime.diffuse': 'hemisphere'}, 'E7'); "
            "print(json.dumps([r.techniques['diffuse'], r.psnr, r.realtime_ms['total']]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path,
                         env={**os.environ, "PYTHONPATH": pythonpath(site, ROOT),
                              "IBLCHECK_CACHE": str(tmp_path / "cache")}, timeout=600)
    diffuse, psnr, total_ms = json.loads(out.stdout.strip().splitlines()[-1])
    assert diffuse == "hemisphere" and 10.0 < psnr < 60.0 and total_ms > 0.0


def test_commands_that_list_every_technique_say_a_plugin_was_left_out(tmp_path):
    """`sweep --technique-axes` and `paper` would leave a broken plugin out silently: one warning line names
    it (the sweep's bad --face-sizes then ends the run before anything renders)."""
    site = broken_copy(tmp_path, _import_error)
    r = iblcheck(site, "sweep", "builtin:sphere-diffuse", "--technique-axes", "--face-sizes", "abc", "--out",
                 str(tmp_path / "s"), cwd=tmp_path)
    said = [x for x in r.stderr.splitlines() if x.startswith("warning:")]
    assert r.returncode == 2 and len(said) == 1 and f"'{DIST}'" in said[0] and "left out" in said[0], r.stderr
    plain = iblcheck(site, "sweep", "builtin:sphere-diffuse", "--face-sizes", "abc", "--out", str(tmp_path / "t"),
                     cwd=tmp_path)
    assert plain.returncode == 2 and "warning:" not in plain.stderr  # the control: no technique listed
