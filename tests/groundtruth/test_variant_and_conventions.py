"""Variant choice and the scene hand-over's conventions (docs/contract.md section 2)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import groundtruth
from groundtruth.pathtracer import mitsuba_scene, variant
from tests.groundtruth.common import small

ROOT = Path(__file__).resolve().parents[2]


def test_variant_order_prefers_llvm_with_a_new_libllvm(monkeypatch):
    monkeypatch.delenv("IBLCHECK_VARIANT", raising=False)
    monkeypatch.setattr(variant, "_nvidia_gpu_present", lambda: False)
    monkeypatch.setattr(variant, "find_libllvm", lambda: "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
    assert variant.candidate_variants() == ["llvm_ad_rgb", "scalar_rgb"]
    monkeypatch.setattr(variant, "find_libllvm", lambda: None)
    assert variant.candidate_variants() == ["scalar_rgb"]
    monkeypatch.setattr(variant, "_nvidia_gpu_present", lambda: True)
    assert variant.candidate_variants()[0] == "cuda_ad_rgb"
    monkeypatch.setenv("IBLCHECK_VARIANT", "scalar_rgb")
    assert variant.candidate_variants() == ["scalar_rgb"]


@pytest.mark.parametrize(("path", "version"), [("/usr/lib/x86_64-linux-gnu/libLLVM-15.so", 15),
                                               ("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1", 19),
                                               ("/usr/lib/llvm-17/lib/libLLVM.so", 17)])
def test_llvm_version_from_file_names(path, version):
    assert variant.llvm_version(path) == version


@pytest.mark.mitsuba
@pytest.mark.parametrize("spec", ["builtin:sphere-blend", "builtin:pawn-pbr"])  # each BSDF plugin
def test_scalar_variant_gives_the_same_image_statistics(tmp_path, monkeypatch, spec):
    """IBLCHECK_VARIANT=scalar_rgb (another process): same mean radiance within noise, meta names it."""
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    scene = small(spec, size=16, spp=64)
    code = (f"import json, groundtruth, scenes, numpy as np; s = scenes.load('{spec}').with_overrides("
            "{'camera.width': 16, 'camera.height': 16, 'reference.spp': 64}); r = groundtruth.render(s); "
            "print(json.dumps({'variant': r.meta['variant'], 'rgb': r.rgb.tolist(), 'mask': r.mask.tolist()}))")
    env = {**os.environ, "IBLCHECK_VARIANT": "scalar_rgb", "IBLCHECK_CACHE": str(tmp_path / "cache"),
           "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert out.returncode == 0, out.stderr
    scalar = json.loads(out.stdout.strip().splitlines()[-1])
    assert scalar["variant"] == "scalar_rgb"
    a, b = groundtruth.render_pair(scene)  # this process: llvm_ad_rgb
    mask = a.mask & np.asarray(scalar["mask"])
    sigma = np.std((a.rgb - b.rgb)[mask]) / np.sqrt(2)
    diff = np.asarray(scalar["rgb"])[mask].mean() - a.rgb[mask].mean()
    assert abs(diff) < 5 * sigma * np.sqrt(2.0 / (mask.sum() * 3)) + 1e-4, (diff, sigma)
    # coverage is decided per pixel by the share of its samples that hit (at least half), so silhouette pixels
    # near half covered flip between independent renders: the scalar variant's mask may differ from this
    # process's by no more than twice what a second seed of this process's variant does (and 4 pixels)
    seed_noise = int((a.mask != b.mask).sum())
    assert (np.asarray(scalar["mask"]) != a.mask).sum() <= max(4, 2 * seed_noise), seed_noise


@pytest.mark.mitsuba
def test_object_lands_where_the_camera_projects_it(tmp_path, monkeypatch):
    """A small sphere up and to the right in world space is up and to the right in the image
    (row 0 at the top, film +X not mirrored), centred where `Camera.project` puts it."""
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    centre = np.array([0.9, 0.5, 0.0])
    scene = small("builtin:sphere-diffuse", size=64, spp=8, **{"objects.0.translate": list(centre),
                                                              "objects.0.scale": 0.3,
                                                              "camera.origin": [0.0, 0.0, 5.0]})
    r = groundtruth.render(scene)
    rows, cols = np.nonzero(r.mask)
    col, row = scene.camera.project(centre)
    assert abs(cols.mean() + 0.5 - col) < 0.5 and abs(rows.mean() + 0.5 - row) < 0.5
    assert col > 32 and row < 32


@pytest.mark.parametrize(("integrator", "objects", "expected"), [
    ("auto", 1, "direct"), ("auto", 2, "path"), ("path", 1, "path"), ("direct", 2, "direct")])
def test_integrator_follows_the_effects(integrator, objects, expected):
    scene = small("builtin:sphere-diffuse", **{"reference.integrator": integrator})
    if objects == 2:
        import scenes

        tree = dict(scene.source)
        tree["objects"] = [dict(tree["objects"][0]), {**tree["objects"][0], "translate": [2.5, 0.0, 0.0]}]
        scene = scenes.model.scene.from_dict(tree, "two.toml", ROOT, "two")
    assert mitsuba_scene.integrator_kind(scene) == expected
    depth = mitsuba_scene.integrator_dict(scene)["max_depth"]
    assert depth == (2 if expected == "direct" else scene.reference.max_depth)


@pytest.mark.parametrize("f0", [0.02, 0.04, 0.5, 0.9])
def test_physical_model_ior_reproduces_f0(f0):
    n = mitsuba_scene.f0_to_ior(f0)
    assert ((n - 1) / (n + 1)) ** 2 == pytest.approx(f0, rel=1e-9)


@pytest.mark.parametrize(("exponent", "alpha"), [(0.0, 1.0), (2.0, np.sqrt(0.5)), (198.0, 0.1)])
def test_phong_exponent_to_ggx_alpha(exponent, alpha):
    assert mitsuba_scene.phong_to_alpha(exponent) == pytest.approx(alpha)


@pytest.mark.mitsuba
def test_plugin_diffuse_equals_mitsubas_builtin_diffuse(tmp_path, monkeypatch):
    """model = "physical" maps diffuse to Mitsuba's own `diffuse`: the same image within noise."""
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    from experiments.measure import metrics

    scene = small("builtin:sphere-diffuse", size=32, spp=256)
    p1, p2 = groundtruth.render_pair(scene)
    m = groundtruth.render(scene.with_overrides({"reference.model": "physical"}))
    assert m.meta["model"] == "physical" and p1.meta["key"] != m.meta["key"]
    mask = metrics.common_mask(p1.mask, m.mask)
    d = lambda x: metrics.display(scene, x)  # noqa: E731
    floor = metrics.noise_floor_psnr(d(p1.rgb), d(p2.rgb), mask)
    # two independent noisy renders: their PSNR sits 3 dB under the floor
    assert metrics.psnr(d(m.rgb), d(p1.rgb), mask) >= floor - 3.0 - 1.0


@pytest.mark.mitsuba
def test_physical_blend_renders_finite(tmp_path, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    scene = small("builtin:sphere-blend", size=16, spp=16, **{"reference.model": "physical"})
    out = groundtruth.render(scene)
    assert np.isfinite(out.rgb).all() and out.mask.any() and out.rgb[out.mask].mean() > 0
