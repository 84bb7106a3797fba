"""Environment maps that are hard or broken: refused clearly (exit 2) or rendered finite."""

from __future__ import annotations

import numpy as np
import pytest

import realtime
import scenes
from groundtruth.exact import quadrature
from tests.hard.common import one_error_line, run_cli, write_env, write_tiny


def env_scene(tmp_path, rgb: np.ndarray, suffix: str = ".exr", material: str = '{ type = "blend" }') -> scenes.Scene:
    write_env(tmp_path / f"env{suffix}", rgb)
    return scenes.load(write_tiny(tmp_path, env=f"env{suffix}", material=material))


@pytest.mark.parametrize(("value", "word"), [(np.nan, "nan"), (np.inf, "inf"), (-1.0, "-1.0")])
def test_invalid_pixels_refused_then_sanitized(tmp_path, value, word):
    rgb = np.ones((16, 32, 3), np.float32)
    rgb[3, 5, 1] = value
    rgb[9, 1, 0] = value
    write_env(tmp_path / "env.exr", rgb)
    path = write_tiny(tmp_path, env="env.exr")
    line = one_error_line(run_cli("render", str(path), "-o", str(tmp_path / "o.exr")))
    assert "env.exr" in line and "2 invalid radiance values" in line and "--sanitize" in line, line
    # the first bad value itself, read from where the message puts it (the fixed text around it says
    # "NaN, Inf or negative" whatever the value, so a search of the whole line could not fail)
    assert "first at row 3, column 5, channel G = " in line, line
    shown = line.split("channel G = ", 1)[1].split(";", 1)[0]
    assert word in shown.lower(), line
    ok = run_cli("render", str(path), "-o", str(tmp_path / "o.exr"), "--sanitize")
    assert ok.returncode == 0, ok.stderr
    assert "replaced 2" in ok.stderr
    out = scenes.storage.imageio.read_exr(tmp_path / "o.exr")
    # sanitized means those pixels are 0: the same image as a map that holds 0 there to begin with
    rgb[3, 5, 1] = rgb[9, 1, 0] = 0.0
    write_env(tmp_path / "zeroed.exr", rgb)
    zeroed_scene = write_tiny(tmp_path, env="zeroed.exr", name="zeroed")
    zeroed = run_cli("render", str(zeroed_scene), "-o", str(tmp_path / "z.exr"))
    assert zeroed.returncode == 0, zeroed.stderr
    np.testing.assert_array_equal(out, scenes.storage.imageio.read_exr(tmp_path / "z.exr"))


@pytest.mark.parametrize("damage", ["truncate", "garbage"])
@pytest.mark.parametrize("suffix", [".exr", ".hdr", ".pfm"])
def test_corrupt_or_truncated_maps_exit_2(tmp_path, damage, suffix):
    write_env(tmp_path / f"env{suffix}", np.ones((16, 32, 3), np.float32))
    p = tmp_path / f"env{suffix}"
    data = p.read_bytes()
    p.write_bytes(data[: len(data) // 2] if damage == "truncate" else b"\x00garbage" * 20)
    line = one_error_line(run_cli("render", str(write_tiny(tmp_path, env=f"env{suffix}"))))
    assert f"env{suffix}" in line


def test_wrong_channel_count_exits_2(tmp_path):
    import OpenEXR

    two = {"R": np.ones((8, 16), np.float32), "G": np.ones((8, 16), np.float32)}
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, two) as f:
        f.write(str(tmp_path / "env.exr"))
    line = one_error_line(run_cli("render", str(write_tiny(tmp_path, env="env.exr"))))
    assert "env.exr" in line and "channel" in line


def test_too_large_is_refused_before_allocating(tmp_path, monkeypatch):
    from scenes import EnvMapError
    from scenes.environment import envmap
    from scenes.storage import imageio

    write_env(tmp_path / "env.exr", np.ones((64, 128, 3), np.float32))
    monkeypatch.setattr(imageio, "MAX_PIXELS", 1000)
    with pytest.raises(EnvMapError, match="env.exr"):
        envmap.read(tmp_path / "env.exr")


@pytest.mark.gl
def test_all_black_environment_is_an_empty_comparison(tmp_path):
    scene = env_scene(tmp_path, np.zeros((16, 32, 3), np.float32))
    rt, q = realtime.render(scene), quadrature.render(scene, subpixels=1)
    assert (rt.rgb == 0).all() and (q.rgb == 0).all()
    from experiments import compare

    # both black: an empty comparison (no lit pixel in the reference), its metrics null, never PSNR 100
    from experiments.measure.pair import EmptyComparison

    with pytest.warns(EmptyComparison, match="no lit pixel"):
        out = compare(rt, q, scene)
    assert (out["psnr"], out["ssim"], out["flip"], out["rel_mse"]) == (None, None, None, None)
    assert "no lit pixel" in out["no_signal"] and out["pixels"] > 0


@pytest.mark.gl
@pytest.mark.parametrize("material", ['{ type = "diffuse" }', '{ type = "phong", exponent = 1000.0 }'])
def test_single_hot_pixel_of_1e6(tmp_path, material):
    rgb = np.full((32, 64, 3), 0.1, np.float32)
    rgb[10, 20] = 1e6
    scene = env_scene(tmp_path, rgb, material=material)
    rt, q = realtime.render(scene), quadrature.render(scene, subpixels=1)
    for img in (rt.rgb, q.rgb):
        assert np.isfinite(img).all() and img.min() >= 0
    # energy: the diffuse sphere's mean radiance is about kd * (mean of the map) for SH9 and quadrature alike
    if "diffuse" in material:
        both = rt.mask & q.mask
        assert rt.rgb[both].mean() == pytest.approx(q.rgb[both].mean(), rel=0.05)


@pytest.mark.gl
def test_single_hot_pixel_of_1e6_in_the_glossy_chain(tmp_path):
    """The glossy image of a 1e6 hot pixel is the numpy box chain read at level 2 (face 64 of base 256)
    along each mirror direction: the background exactly (0.1, median error 0), the blurred hot spot
    (3.5e5, 3.5e6 times the background) within 10 % where the tessellated normals steer a steep gradient."""
    from tests.helpers import box_chain, trilinear, unit_sphere_hits

    rgb = np.full((32, 64, 3), 0.1, np.float32)
    rgb[10, 20] = 1e6
    write_env(tmp_path / "env.exr", rgb)
    scene = scenes.load(write_tiny(tmp_path, env="env.exr", material='{ type = "phong", exponent = 1000.0 }',
                                   size=32))
    rt = realtime.render(scene)
    n, v, interior = unit_sphere_hits(scene.camera)
    mirror = 2 * np.sum(n * v, axis=-1, keepdims=True) * n - v
    chain = box_chain(scenes.environment.envmap.read(tmp_path / "env.exr"), 256)
    expected, inside = trilinear(chain, mirror.reshape(-1, 3), 2.0)
    expected, inside = expected.reshape(rt.rgb.shape), inside.reshape(rt.mask.shape)
    sel = interior & rt.mask & inside
    assert expected[sel].max() > 1e5  # the hot spot is in view
    rel = np.abs(rt.rgb[sel] - expected[sel]) / expected[sel]
    assert np.median(rel) < 1e-5 and rel.max() < 0.1, (np.median(rel), rel.max())


@pytest.mark.gl
def test_values_above_half_float_range_survive(tmp_path):
    """1e6 > 65504 (the half-float maximum): textures are 32-bit, so kd * L comes out, not Inf."""
    scene = env_scene(tmp_path, np.full((16, 32, 3), 1e6, np.float32),
                      material='{ type = "diffuse", kd = [0.5, 0.5, 0.5] }')
    rt = realtime.render(scene)
    assert np.isfinite(rt.rgb).all()
    np.testing.assert_allclose(rt.rgb[rt.mask], 5e5, rtol=1e-3)
