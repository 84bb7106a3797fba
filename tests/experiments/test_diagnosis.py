"""`iblcheck diagnose` names exactly the convention mistakes planted in an engine image of builtin:calibration.

Each planted image is the scene's reference rendered with the second seed (independent noise, as another
renderer's image would have) and then made wrong by a route written here, never through the diagnosis'
forward models: a flip with numpy, a re-render with the changed scene key, the map u-mirrored as an
engine mirrors it (exported to the viewer convention, its columns reversed there, read back), sRGB and
the half-pixel shift by this file's own formulas (the shift from a 4x supersampled render, the diagnosis
uses 2x). A correct image (the second seed; the real-time render) must give no mistake. The fitted angle
must be within ANGLE_TOL_DEG, the fitted exposure within EXPOSURE_TOL (relative).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest

import scenes
from experiments.measure import diagnosis, engine_image
from experiments.measure.diagnosis import fitting, hypotheses
from experiments.measure.diagnosis.display import Display
from scenes.environment import envmap
from scenes.environment.calibration import calibration_map
from scenes.environment.directions import equirect_directions
from scenes.exchange import viewer_equirect
from scenes.model import tone_operators
from scenes.storage import imageio

ANGLE_TOL_DEG = 1.0
EXPOSURE_TOL = 0.02
ANGLE = 37.0
FACTORS = {"mirror_x+exposure": 1.7, "exposure": 0.6}


# --------------------------------------------------------------------------- pure forward pieces (fast)


def test_half_pixel_shift_of_a_ramp_is_the_ramp_half_a_pixel_back():
    # a 2x render of f(x) = x (pixel units, box filtered): sub-pixel b holds the mean over [b/2, (b+1)/2]
    w = 6
    sub = (np.arange(2 * w) + 0.5) / 2.0
    s = np.broadcast_to(sub[None, :, None], (4, 2 * w, 1))
    shifted = hypotheses.half_pixel_shift(s)[0, :, 0]
    # pixel j over [j - 1/2, j + 1/2] has mean j; the first repeats column 0 of the 2x image (its edge rule)
    assert np.allclose(shifted[1:], np.arange(1, w))
    assert np.isclose(shifted[0], 0.25)
    assert np.allclose(hypotheses.block_average(s)[0, :, 0], np.arange(w) + 0.5)  # control: unshifted


def test_horizontal_fov_relation():
    assert math.isclose(hypotheses.horizontal_fov_as_vertical(40.0, 64, 64), 40.0)
    # 90 degrees across 2:1 -> tan(v/2) = 1/2
    assert math.isclose(hypotheses.horizontal_fov_as_vertical(90.0, 128, 64), math.degrees(2 * math.atan(0.5)))


Z_MIRROR = np.array([1.0, 1.0, -1.0])  # the viewer file's u -> 1 - u (atan2(d.z, d.x) -> -atan2(d.z, d.x))
X_MIRROR = np.array([-1.0, 1.0, 1.0])  # iblcheck's own u -> 1 - u: the negative control


def _unit(n: int, seed: int) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("width", [32, 36])
def test_u_mirror_is_the_lookup_at_z_mirrored_directions(width):
    env = calibration_map(16, width).astype(np.float32)
    d = _unit(500, 1)
    mirrored = envmap.lookup(hypotheses.mirror_u(env), d)
    assert np.allclose(mirrored, envmap.lookup(env, d * Z_MIRROR), atol=1e-5)
    assert not np.allclose(mirrored, envmap.lookup(env, d * X_MIRROR), atol=1e-2)  # control: x mirror


def test_u_mirror_is_the_viewer_files_u_mirror():
    # the route an engine takes: iblcheck's map exported to the viewer convention and read at 1 - u. At
    # the viewer's texel centres (mirrored, still centres) the export is exact, so both must agree there
    env = calibration_map(16, 32).astype(np.float32)
    vmap = viewer_equirect.to_viewer(env)
    centres = viewer_equirect.texel_directions(16, 32).reshape(-1, 3)
    u, t = viewer_equirect.viewer_uv(centres)
    engine = viewer_equirect.lookup(vmap, viewer_equirect.viewer_direction(1.0 - u, t))
    assert np.allclose(engine, envmap.lookup(hypotheses.mirror_u(env), centres), atol=1e-5)
    assert not np.allclose(engine, envmap.lookup(env[:, ::-1], centres), atol=1e-2)  # control: x mirror


def test_u_mirror_of_an_odd_width_is_exact_at_the_texel_centres():
    env = calibration_map(16, 33).astype(np.float32)
    centres = equirect_directions(16, 33)[1:-1]  # the poles' rows: one direction, no u to mirror
    mirrored = hypotheses.mirror_u(env)[1:-1]
    assert np.allclose(mirrored, envmap.lookup(env, centres * Z_MIRROR), atol=1e-5)
    assert not np.allclose(mirrored, envmap.lookup(env, centres * X_MIRROR), atol=1e-2)


def test_srgb_and_exposure_by_hand():
    assert np.allclose(hypotheses.srgb_oetf(np.array([0.0, 0.001, 0.5, 1.0, 4.0])),
                       [0.0, 0.01292, 0.735357, 1.0, 1.055 * 4 ** (1 / 2.4) - 0.055], atol=1e-6)
    p = np.random.default_rng(2).random((8, 8, 3))
    mask = np.ones((8, 8), bool)
    assert math.isclose(hypotheses.fit_exposure(p, 2.5 * p, mask), 2.5)


@pytest.mark.parametrize("minimum", [0.0, 0.4, -0.7, 3.6, -5.2])
def test_the_final_parabola_walks_to_a_minimum_beyond_its_window(minimum):
    """A quadratic's minimum is found exactly from 0 with a window of +-1, however far (up to the walk's
    reach) it lies: the proxy's best angle can be degrees off the reference's."""
    calls = []

    def f(x):
        calls.append(x)
        return (x - minimum) ** 2 + 2.0

    assert fitting.parabola_walk(f, 0.0, 1.0, fitting.MAX_WALK) == pytest.approx(minimum, abs=1e-9)
    # the control: the single parabola the walk starts with stops at its window's edge
    assert fitting._parabola_vertex(f, 0.0, 1.0) == pytest.approx(float(np.clip(minimum, -1.0, 1.0)), abs=1e-9)
    assert len(calls) <= 3 * (fitting.MAX_WALK + 1) + 3


# --------------------------------------------------------------------------- planted mistakes (Mitsuba)


def _srgb(x):  # IEC 61966-2-1, not clamped above 1
    x = np.maximum(x, 0.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


@pytest.fixture(scope="module")
def calibration():
    return scenes.load("builtin:calibration")


@pytest.fixture(scope="module")
def plant(calibration, tmp_path_factory):
    """plant(names) -> the second-seed image of builtin:calibration with the planted mistakes."""
    import groundtruth  # deferred: Mitsuba starts only for the tests that plant
    from groundtruth.pathtracer.reference import second_seed

    seed = second_seed(calibration.reference.seed)
    folder = tmp_path_factory.mktemp("planted")

    def render(overrides: dict, factor: int = 1, spp: int | None = None) -> np.ndarray:
        c = calibration.camera
        overrides = {**overrides, "camera.width": c.width * factor, "camera.height": c.height * factor}
        return np.asarray(groundtruth.render(calibration.with_overrides(overrides), spp=spp, seed=seed).rgb,
                          np.float64)

    def make(names: tuple[str, ...], pair: str) -> np.ndarray:
        overrides: dict = {}
        if "env_rotation" in names:
            overrides["environment.rotation_deg"] = ANGLE
        if "env_u_mirror" in names:
            # the engine's route: the map exported to the viewer convention, its u mirrored there (columns
            # reversed: texel W - 1 - c is centred at 1 - u), read back into iblcheck's convention
            vmap = viewer_equirect.to_viewer(calibration.environment.radiance())
            path = folder / "u-mirrored.exr"
            imageio.write_exr(path, viewer_equirect.from_viewer(vmap[:, ::-1]))
            overrides["environment.map"] = str(path)
        if "fov_horizontal" in names:
            c = calibration.camera
            overrides["camera.fov_deg"] = math.degrees(2 * math.atan(math.tan(math.radians(c.fov_deg / 2)) / c.aspect))
        if "half_pixel" in names:
            big = render(overrides, 4, spp=max(1, calibration.reference.spp // 16))
            big = np.concatenate([big[:2], big], axis=0)[:-2]  # two sub-rows up: row -1/2 .. row H - 1/2
            big = np.concatenate([big[:, :2], big], axis=1)[:, :-2]
            img = big.reshape(big.shape[0] // 4, 4, big.shape[1] // 4, 4, 3).mean(axis=(1, 3))
        else:
            img = render(overrides)
        if "tonemap" in names:
            img = tone_operators.apply("agx", img)
        if "srgb_encoded" in names:
            img = _srgb(img)
        if "exposure" in names:
            img = img * FACTORS[pair if pair in FACTORS else "exposure"]
        if "mirror_x" in names:
            img = img[:, ::-1]
        if "mirror_y" in names:
            img = img[::-1]
        return img

    return make


def _check(found: diagnosis.Diagnosis, planted: tuple[str, ...], pair: str):
    names = {s.name: s for s in found.mistakes}
    assert set(names) == set(planted), (planted, found)
    for s in found.mistakes:
        assert s.gain_db >= s.threshold_db >= 1.0
    if "env_rotation" in names:
        assert abs(names["env_rotation"].parameter - ANGLE) <= ANGLE_TOL_DEG
    if "exposure" in names:
        want = FACTORS[pair if pair in FACTORS else "exposure"]
        assert abs(names["exposure"].parameter / want - 1) <= EXPOSURE_TOL
    if "tonemap" in names:
        assert names["tonemap"].parameter == "agx"
    assert found.psnr_after >= found.psnr_before + 1.0


CASES = [(n,) for n in hypotheses.FOR_IMAGE[hypotheses.LINEAR]] + [
    ("mirror_x", "exposure"), ("env_rotation", "srgb_encoded"), ("fov_horizontal", "half_pixel"),
    ("env_u_mirror", "tonemap"), ("mirror_y", "env_rotation"), ("srgb_encoded", "exposure"),
    ("mirror_x", "mirror_y"), ("fov_horizontal", "env_u_mirror")]


@pytest.mark.mitsuba
@pytest.mark.slow
@pytest.mark.parametrize("planted", CASES, ids=["+".join(c) for c in CASES])
def test_the_planted_mistakes_are_named(calibration, plant, planted):
    pair = "+".join(planted)
    _check(diagnosis.diagnose(calibration, plant(planted, pair)), planted, pair)


@pytest.mark.mitsuba
@pytest.mark.slow
def test_a_correct_image_gives_nothing(calibration, plant):
    found = diagnosis.diagnose(calibration, plant((), ""))
    assert found.mistakes == ()
    assert found.psnr_after == found.psnr_before


@pytest.mark.mitsuba
@pytest.mark.slow
def test_a_wrong_forward_model_misses_its_mistake(calibration, plant, monkeypatch):
    """Negative control: with mirror_x's model broken (no flip), the planted flip is not explained by it."""
    monkeypatch.setattr(fitting.hypotheses, "flip", lambda rgb, mistakes: rgb)
    found = diagnosis.diagnose(calibration, plant(("mirror_x",), "mirror_x"))
    assert "mirror_x" not in {s.name for s in found.mistakes}


@pytest.mark.gl
@pytest.mark.mitsuba
@pytest.mark.slow
def test_the_realtime_render_gives_nothing(calibration):
    import realtime  # deferred: needs an OpenGL context

    found = diagnosis.diagnose(calibration, np.asarray(realtime.render(calibration).rgb, np.float64))
    assert found.mistakes == (), found


# --------------------------------------------------------------------------- display images (PNG)
# The test's own tone operators and encoding: three.js ACESFilmicToneMapping (Hill's fit) written with
# the matrices in the row form of Hill's HLSL (ACESFitted.hlsl: mul(M, color)), and Reinhard's per-channel
# x / (1 + x); sRGB clipped to [0, 1] and rounded to 8 bits, as an engine writes a PNG.

ACES_IN_ROWS = np.array([[0.59719, 0.35458, 0.04823], [0.07600, 0.90834, 0.01566], [0.02840, 0.13383, 0.83777]])
ACES_OUT_ROWS = np.array([[1.60475, -0.53108, -0.07367], [-0.10208, 1.10813, -0.00605],
                          [-0.00327, -0.07276, 1.07602]])
DISPLAY_FACTOR = 2.5  # the planted exposure mistake, before the operator


def _aces_hill(x):
    v = np.einsum("ij,...j->...i", ACES_IN_ROWS, np.asarray(x, np.float64) / 0.6)
    v = (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.4329510) + 0.238081)
    return np.clip(np.einsum("ij,...j->...i", ACES_OUT_ROWS, v), 0.0, 1.0)


def _reinhard(x):
    x = np.maximum(x, 0.0)
    return np.clip(x / (1.0 + x), 0.0, 1.0)


def _png_codes(x):
    return np.round(np.clip(x, 0.0, 1.0) * 255.0).astype(np.uint8)


def _display_planted(ref: np.ndarray, planted: str) -> np.ndarray:
    """8-bit code values of the reference as an engine told to use aces-hill, exposure 1, wrote them."""
    if planted == "srgb_not_encoded":
        return _png_codes(_aces_hill(ref))
    if planted == "srgb_twice":
        return _png_codes(_srgb(np.clip(_srgb(np.clip(_aces_hill(ref), 0, 1)), 0, 1)))
    if planted == "exposure":
        return _png_codes(_srgb(_aces_hill(DISPLAY_FACTOR * ref)))
    if planted == "tonemap":
        return _png_codes(_srgb(_reinhard(ref)))
    codes = _png_codes(_srgb(_aces_hill(ref)))
    return codes[:, ::-1] if planted == "mirror_x" else codes


@pytest.mark.parametrize("mistakes", [{}, {"srgb_twice": None}, {"srgb_not_encoded": None},
                                      {"exposure": 0.7}, {"tonemap": "reinhard"}])
def test_the_display_model_is_the_tests_own_pipeline(mistakes):
    rgb = np.random.default_rng(4).gamma(0.7, 1.0, size=(16, 16, 3))
    model = Display("aces-hill", 1.0, 8).encode(rgb, mistakes)
    scale = mistakes.get("exposure", 1.0)
    curve = _reinhard(rgb) if "tonemap" in mistakes else _aces_hill(scale * rgb)
    codes = (curve if "srgb_not_encoded" in mistakes else
             _srgb(np.clip(_srgb(curve), 0, 1)) if "srgb_twice" in mistakes else _srgb(curve))
    assert np.array_equal(model, _png_codes(codes) / 255.0)
    assert not np.allclose(Display("aces-hill", 1.0, 8).encode(rgb, {**mistakes, "srgb_twice": None}
                                                                if "srgb_twice" not in mistakes else {}),
                           model, atol=0.02)  # control: the encoding once more or once less


def test_the_display_exposure_is_recovered():
    rgb = np.random.default_rng(5).uniform(0.0, 0.4, size=(32, 32, 3))  # the curve unsaturated: its shape shows
    target = _png_codes(_srgb(_aces_hill(DISPLAY_FACTOR * rgb))) / 255.0
    mask = np.ones((32, 32), bool)
    k = Display("aces-hill", 1.0, 8).fit_exposure(rgb, {"exposure": 1.0}, target[mask], mask)
    assert abs(k / DISPLAY_FACTOR - 1) <= EXPOSURE_TOL
    wrong = Display("reinhard", 1.0, 8).fit_exposure(rgb, {"exposure": 1.0}, target[mask], mask)
    assert abs(wrong / DISPLAY_FACTOR - 1) > EXPOSURE_TOL  # control: through another operator


@pytest.fixture(scope="module")
def png(plant, calibration, tmp_path_factory):
    """png(planted) -> the path of an 8-bit PNG of the second-seed reference with `planted` ("" for none)."""
    ref = plant((), "")
    folder = tmp_path_factory.mktemp("png")

    def make(planted: str):
        path = folder / f"engine-{planted or 'correct'}.png"
        iio.imwrite(path, _display_planted(ref, planted))
        return path

    return make


DISPLAY_CASES = ["srgb_twice", "srgb_not_encoded", "mirror_x", "exposure", "tonemap"]


@pytest.mark.mitsuba
@pytest.mark.slow
@pytest.mark.parametrize("planted", DISPLAY_CASES)
def test_the_planted_display_mistakes_are_named(calibration, png, planted):
    image = engine_image.read_engine_image(png(planted), calibration, "srgb", "aces-hill", 1.0)
    found = diagnosis.diagnose(calibration, image.values, display=Display(image.tonemap, image.exposure, image.bits))
    names = {s.name: s for s in found.mistakes}
    assert set(names) == {planted}, found
    assert names[planted].gain_db >= names[planted].threshold_db >= 1.0
    if planted == "exposure":
        assert abs(names["exposure"].parameter / DISPLAY_FACTOR - 1) <= EXPOSURE_TOL
    if planted == "tonemap":
        assert names["tonemap"].parameter == "reinhard"
    assert found.psnr_after >= found.psnr_before + 1.0


@pytest.mark.mitsuba
@pytest.mark.slow
def test_a_correct_png_gives_nothing(png):
    r = _iblcheck("diagnose", "builtin:calibration", "--image", str(png("")), "--image-encoding", "srgb",
                  "--tonemap", "aces-hill", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["mistakes"] == [] and out["encoding"] == "srgb"
    assert "srgb_twice" in out["tested"] and "srgb_encoded" not in out["tested"]


@pytest.mark.parametrize("flags", [(), ("--image-encoding", "srgb")])
def test_a_png_without_its_tonemap_exits_2(tmp_path, flags):
    path = tmp_path / "engine.png"
    iio.imwrite(path, np.zeros((64, 96, 3), np.uint8))
    r = _iblcheck("diagnose", "builtin:calibration", "--image", str(path), *flags)
    assert r.returncode == 2 and r.stderr.startswith("error:") and "--tonemap" in r.stderr, r.stderr
    assert "engine.png" in r.stderr


# --------------------------------------------------------------------------- the command


def _iblcheck(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "experiments.cli", *args], capture_output=True, text=True)


@pytest.mark.parametrize("size", [(64, 64), (96, 63)])
def test_an_image_of_the_wrong_size_exits_2(tmp_path, size):
    path = tmp_path / "engine.exr"
    imageio.write_exr(path, np.ones((size[1], size[0], 3), np.float32))
    r = _iblcheck("diagnose", "builtin:calibration", "--image", str(path))
    assert r.returncode == 2 and r.stderr.startswith("error:") and "engine.exr" in r.stderr, r.stderr


def test_a_missing_image_exits_2(tmp_path):
    r = _iblcheck("diagnose", "builtin:calibration", "--image", str(tmp_path / "none.exr"))
    assert r.returncode == 2 and "none.exr" in r.stderr, r.stderr


@pytest.mark.mitsuba
@pytest.mark.slow
def test_the_command_reports_a_flip_in_json(tmp_path, plant):
    path = tmp_path / "engine.exr"
    imageio.write_exr(path, plant(("mirror_y",), "mirror_y").astype(np.float32))
    r = _iblcheck("diagnose", "builtin:calibration", "--image", str(path), "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert [m["name"] for m in out["mistakes"]] == ["mirror_y"]
    assert out["psnr_after"] > out["psnr_before"]
