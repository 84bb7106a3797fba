"""Engine images scored against the reference (experiments/measure/engine_image.py, `compare --image`).

The key property: iblcheck's own real-time render, saved as EXR and scored as an engine image, gives
exactly the metrics `iblcheck compare` gives (a second path to the same numbers); saved as an 8-bit PNG
after aces-hill it scores within 0.5 dB of the display-space PSNR computed here by hand, and declared
with the wrong operator it scores lower (negative control).
"""

from __future__ import annotations

import gc
import json
import warnings

import imageio.v3 as iio
import numpy as np
import pytest

import groundtruth
import scenes
from experiments.cli import main as cli
from experiments.measure import comparison, engine_image, metrics
from scenes import InputError
from scenes.model import tone_operators
from scenes.model.render import Render
from scenes.model.tonemap import adaptation_luminance, srgb_encode, to_uint8
from scenes.storage.imageio import write_exr, write_pfm
from tests.scenes.test_png16 import encode as encode_png16

SCENE = "builtin:sphere-diffuse"
TINY = ["camera.width=64", "camera.height=64", "reference.spp=64", "realtime.timing_frames=2",
        "realtime.warmup_frames=1"]


def sets() -> list[str]:
    return [x for kv in TINY for x in ("--set", kv)]


@pytest.fixture(scope="module")
def scene():
    return scenes.load(SCENE).with_overrides(dict(kv.split("=") for kv in TINY))


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(autouse=True)
def _cache_env(cache, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(cache))


# --------------------------------------------------------------------------- reading: every bad file named


def test_errors_name_the_file(scene, tmp_path):
    good = np.full((64, 64, 3), 0.5, np.float32)
    cases = {}
    write_exr(tmp_path / "small.exr", good[:32])
    cases["small.exr"] = "64 x 64"
    bad = good.copy()
    bad[3, 5, 1] = np.nan
    write_pfm(tmp_path / "nan.pfm", bad)
    cases["nan.pfm"] = "NaN or Inf"
    bad = good.copy()
    bad[7, 2, 0] = -1.0
    write_exr(tmp_path / "neg.exr", bad)
    cases["neg.exr"] = "negative"
    cases["missing.exr"] = "not found"
    (tmp_path / "image.tiff").write_bytes(b"II*\0")
    cases["image.tiff"] = "suffix"
    (tmp_path / "corrupt.png").write_bytes(b"not a png")
    for name, why in cases.items():
        with pytest.raises(InputError, match=why) as info:
            engine_image.read_engine_image(tmp_path / name, scene)
        assert str(tmp_path / name) in str(info.value)
    with pytest.raises(InputError, match="not a readable PNG") as info:
        engine_image.read_engine_image(tmp_path / "corrupt.png", scene, "srgb", "agx")
    assert "corrupt.png" in str(info.value)


def test_png_as_linear_refused_and_exr_as_srgb_refused(scene, tmp_path):
    iio.imwrite(tmp_path / "a.png", np.zeros((64, 64, 3), np.uint8))
    with pytest.raises(InputError, match="not linear radiance"):
        engine_image.read_engine_image(tmp_path / "a.png", scene, "linear")
    write_exr(tmp_path / "a.exr", np.zeros((64, 64, 3), np.float32))
    with pytest.raises(InputError, match="holds linear radiance"):
        engine_image.read_engine_image(tmp_path / "a.exr", scene, "srgb", "agx")


def test_an_exr_alpha_is_coverage_and_one_covering_nothing_is_refused(scene, tmp_path):
    rgb = np.full((64, 64, 3), 0.5, np.float32)
    alpha = np.zeros((64, 64), np.float32)
    write_exr(tmp_path / "none.exr", rgb, alpha)
    with pytest.raises(InputError, match=r"none.exr: alpha < 0.5 at every pixel"):
        engine_image.read_engine_image(tmp_path / "none.exr", scene)
    alpha[10:20, 30:40] = 1.0  # the control: some coverage is read as it is
    write_exr(tmp_path / "some.exr", rgb, alpha)
    coverage = engine_image.read_engine_image(tmp_path / "some.exr", scene).coverage
    assert coverage.sum() == 100 and coverage[10:20, 30:40].all()


def test_alpha_is_ignored_and_timings_read(scene, tmp_path):
    rgba = np.zeros((64, 64, 4), np.uint8)
    rgba[..., 0], rgba[..., 3] = 200, 7
    iio.imwrite(tmp_path / "f.png", rgba)
    (tmp_path / "f.timings.json").write_text(json.dumps({"engine": "three.js", "version": "0.181.0",
                                                         "frame_ms": [3.0, 1.0, 2.0], "precompute_ms": 5}))
    img = engine_image.read_engine_image(tmp_path / "f.png", scene, "srgb", "reinhard")
    assert img.alpha_ignored and img.bits == 8 and img.engine == "three.js"
    assert img.values[0, 0].tolist() == [200 / 255, 0.0, 0.0]
    # the median of 1, 2, 3, and its 90th percentile interpolated between 2 and 3
    assert img.timings == {"draw": 2.0, "total": 2.0, "draw_p90": 2.8, "precompute": 5.0}


def test_a_16_bit_rgb_png_keeps_its_16_bits(scene, tmp_path):
    """Pillow alone reads 48-bit PNGs as 8 bits a channel (tests/scenes/test_png16.py)."""
    samples = np.random.default_rng(5).integers(0, 65536, (64, 64, 3), np.uint16)
    (tmp_path / "c.png").write_bytes(encode_png16(samples, 2, [4]))
    img = engine_image.read_engine_image(tmp_path / "c.png", scene, "srgb", "none")
    assert img.bits == 16
    np.testing.assert_array_equal(img.values, samples / 65535.0)


def test_a_file_that_is_no_image_gives_one_error_and_no_warning(scene, tmp_path):
    (tmp_path / "text.jpg").write_text("hello")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(InputError, match="text.jpg: not a readable PNG or JPEG image"):
            engine_image.read_engine_image(tmp_path / "text.jpg", scene, "srgb", "none")
        gc.collect()  # an unclosed file warns when it is collected
    assert [str(w.message) for w in caught] == []


def test_display_reference_quantised_to_the_files_bits(scene, tmp_path):
    rgb = np.random.default_rng(1).uniform(0, 4, (64, 64, 3))
    for bits in (8, 16):
        img = engine_image.EngineImage(tmp_path / "x.png", "srgb", "aces-narkowicz", 1.3, np.zeros((64, 64, 3)), bits)
        out = engine_image.display_reference(rgb, img, scene)
        by_hand = srgb_encode(np.clip(1.3 * rgb * (2.51 * 1.3 * rgb + 0.03) / (1.3 * rgb * (2.43 * 1.3 * rgb + 0.59)
                                                                                 + 0.14), 0, 1))
        step = 1 / ((1 << bits) - 1)
        assert np.abs(out - by_hand).max() <= step / 2 + 1e-12
        assert np.allclose(out / step, np.round(out / step))


# --------------------------------------------------------------------------- scoring through the CLI


@pytest.fixture(scope="module")
def realtime_rgb(scene, cache):
    mp = pytest.MonkeyPatch()
    mp.setenv("IBLCHECK_CACHE", str(cache))
    try:
        return comparison.render_realtime(scene).rgb
    finally:
        mp.undo()


def run_json(args, capsys) -> dict:
    code = cli.main(args)
    out = capsys.readouterr()
    assert code == 0, out.err
    return json.loads(out.out.strip().splitlines()[-1])


@pytest.mark.gl
@pytest.mark.mitsuba
def test_exr_of_the_realtime_render_scores_exactly_as_compare(scene, realtime_rgb, tmp_path, capsys):
    """An engine image carries no coverage (its mask is all True: the reference's decides), so the second
    path equals `compare` of the same pixels with that mask exactly, and `iblcheck compare` (whose mask is
    also the real-time coverage) to within the few silhouette pixels the two coverages differ by."""
    write_exr(tmp_path / "rt.exr", realtime_rgb)
    own = run_json(["compare", SCENE, "--json", *sets()], capsys)
    image = run_json(["compare", SCENE, "--image", str(tmp_path / "rt.exr"), "--json", *sets()], capsys)
    ref = groundtruth.render(scene)
    test = Render(rgb=realtime_rgb, mask=np.ones(realtime_rgb.shape[:2], bool))
    same_pixels = comparison.compare_renders(test, ref, scene).metrics
    for key in ("psnr", "psnr_unbiased", "ssim", "flip", "rel_mse", "noise_floor_psnr", "pixels"):
        assert image[key] == same_pixels[key], key
    print(f"EXR: {image['psnr']:.4f} dB over {image['pixels']} px; iblcheck compare {own['psnr']:.4f} dB over "
          f"{own['pixels']} px")
    assert abs(image["psnr"] - own["psnr"]) < 0.05 and abs(image["pixels"] - own["pixels"]) <= 0.05 * own["pixels"]
    assert image["image"] == str(tmp_path / "rt.exr") and "note" not in image
    # negative control: the image darkened by 30 % no longer scores the same
    write_exr(tmp_path / "dark.exr", realtime_rgb * 0.7)
    dark = run_json(["compare", SCENE, "--image", str(tmp_path / "dark.exr"), "--json", *sets()], capsys)
    assert dark["psnr"] < own["psnr"] - 1.0


@pytest.mark.gl
@pytest.mark.mitsuba
def test_png_after_aces_hill_scores_the_hand_display_psnr(scene, realtime_rgb, tmp_path, capsys):
    png = tmp_path / "rt.png"
    iio.imwrite(png, to_uint8(srgb_encode(tone_operators.apply("aces-hill", realtime_rgb))))
    res = run_json(["compare", SCENE, "--image", str(png), "--image-encoding", "srgb", "--tonemap", "aces-hill",
                    "--json", *sets()], capsys)
    assert res["rel_mse"] is None and res["psnr_unbiased"] is None and "display-space" in res["note"]
    # by hand: the reference through Hill's fit (grey-free: the module's operator, the subject of its own
    # tests), sRGB, no quantisation; the PNG's code values / 255; PSNR over the eroded reference mask
    ref = groundtruth.render(scene)
    b = srgb_encode(tone_operators.apply("aces-hill", ref.rgb))
    a = iio.imread(png).astype(np.float64) / 255
    mask = metrics.common_mask(np.ones((64, 64), bool), ref.mask)
    hand = 10 * np.log10(1 / np.mean((a[mask] - b[mask]) ** 2))
    print(f"display-space PSNR: tool {res['psnr']:.3f} dB, by hand {hand:.3f} dB")
    assert abs(res["psnr"] - hand) < 0.5
    wrong = run_json(["compare", SCENE, "--image", str(png), "--image-encoding", "srgb", "--tonemap", "reinhard",
                      "--json", *sets()], capsys)
    print(f"declared reinhard instead: {wrong['psnr']:.3f} dB")
    assert wrong["psnr"] < res["psnr"] - 1.0


@pytest.mark.gl
@pytest.mark.mitsuba
def test_the_png_of_iblcheck_render_scores_as_compare_with_the_scenes_display_transform(tmp_path, capsys):
    # `iblcheck compare` measures in the scene's display space (Reinhard with the scene's key, white and
    # adaptation, then sRGB): the PNG `iblcheck render` writes holds that image quantised to 8 bits, so
    # scored with --tonemap scene it must give compare's PSNR to within the quantisation and the few
    # silhouette pixels whose coverage differs
    out = tmp_path / "own.exr"
    assert cli.main(["render", SCENE, "-o", str(out), *sets()]) == 0
    own = run_json(["compare", SCENE, "--json", *sets()], capsys)
    png = ["compare", SCENE, "--image", str(out.with_suffix(".png")), "--image-encoding", "srgb", "--json", *sets()]
    res = run_json([*png, "--tonemap", "scene"], capsys)
    # negative control: the engines' plain Reinhard (no key, white or adaptation) is another transform
    wrong = run_json([*png, "--tonemap", "reinhard"], capsys)
    print(f"own PNG with the scene's transform {res['psnr']:.3f} dB, declared reinhard {wrong['psnr']:.3f} dB; "
          f"iblcheck compare {own['psnr']:.3f} dB")
    assert abs(res["psnr"] - own["psnr"]) < 0.5 and res["tonemap"] == "scene" and "display-space" in res["note"]
    assert wrong["psnr"] < res["psnr"] - 1.0


def test_the_scenes_transform_keeps_the_images_exposure_at_1(scene, tmp_path):
    iio.imwrite(tmp_path / "a.png", np.zeros((64, 64, 3), np.uint8))
    with pytest.raises(InputError, match=r"a.png: exposure 2 with tone mapping 'scene'"):
        engine_image.read_engine_image(tmp_path / "a.png", scene, "srgb", "scene", 2.0)
    assert engine_image.read_engine_image(tmp_path / "a.png", scene, "srgb", "scene", 1.0).tonemap == "scene"


def test_the_scenes_transform_is_reinhard_with_the_scenes_key_white_and_adaptation(scene, tmp_path):
    # by hand from Reinhard's eq. 4 and the scene's [tonemap] and environment, then sRGB and 8 bits
    rgb = np.random.default_rng(2).uniform(0, 4, (64, 64, 3))
    img = engine_image.EngineImage(tmp_path / "x.png", "srgb", "scene", 1.0, np.zeros((64, 64, 3)), 8)
    tm = scene.tonemap
    x = np.minimum(rgb * tm.key / adaptation_luminance(scene.environment.radiance()) * 2.0 ** tm.exposure, tm.white)
    by_hand = np.round(255 * srgb_encode(x * (1 + x / tm.white ** 2) / (1 + x))) / 255
    assert np.abs(engine_image.display_reference(rgb, img, scene) - by_hand).max() <= 1 / 255 + 1e-9
    plain = engine_image.EngineImage(tmp_path / "x.png", "srgb", "reinhard", 1.0, np.zeros((64, 64, 3)), 8)
    assert np.abs(engine_image.display_reference(rgb, plain, scene) - by_hand).max() > 0.05  # another transform


@pytest.mark.parametrize("args,why", [
    (["--image-encoding", "srgb"], "--tonemap"),
    ([], "--image-encoding srgb"),
])
def test_png_needs_encoding_and_tonemap(tmp_path, capsys, args, why):
    iio.imwrite(tmp_path / "a.png", np.zeros((64, 64, 3), np.uint8))
    assert cli.main(["compare", SCENE, "--image", str(tmp_path / "a.png"), *args, *sets()]) == 2
    err = capsys.readouterr().err
    assert why in err and "a.png" in err and err.count("\n") == 1


def test_missing_image_exits_2_naming_it(tmp_path, capsys):
    assert cli.main(["compare", SCENE, "--image", str(tmp_path / "none.exr"), *sets()]) == 2
    assert "none.exr" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["compare", "diagnose"])
def test_a_folder_or_missing_image_is_named_before_its_suffix_is_read(tmp_path, capsys, command):
    (tmp_path / "shots").mkdir()
    for path, words in ((tmp_path / "shots", "is a folder, not an image file"), (tmp_path / "no.png", "not found")):
        assert cli.main([command, "builtin:sphere-diffuse", "--image", str(path)]) == 2
        assert capsys.readouterr().err.strip() == f"error: {path}: image file {words}".replace(
            "image file is a folder", "is a folder")
