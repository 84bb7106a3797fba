"""HDR file I/O: round trips, channel order, Mitsuba's own reader as a second opinion, bad files."""

from __future__ import annotations

import numpy as np
import OpenEXR
import pytest

from scenes import EnvMapError
from scenes.environment import envmap
from scenes.storage import imageio


@pytest.fixture
def hdr_image(rng):
    # values spanning 1e-3 .. 1e4, the range of a real probe
    return (10.0 ** rng.uniform(-3, 4, size=(16, 32, 3))).astype(np.float32)


def test_exr_float_round_trip_is_exact(tmp_path, hdr_image):
    envmap.write(tmp_path / "a.exr", hdr_image)
    np.testing.assert_array_equal(envmap.read(tmp_path / "a.exr"), hdr_image)


def test_half_exr_with_bgr_channel_order(tmp_path, hdr_image):
    half = hdr_image.astype(np.float16)
    channels = {"B": half[..., 2].copy(), "G": half[..., 1].copy(), "R": half[..., 0].copy(),
                "A": np.ones(half.shape[:2], np.float16)}
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, channels) as f:
        f.write(str(tmp_path / "bgr.exr"))
    out = envmap.read(tmp_path / "bgr.exr")
    assert out.dtype == np.float32
    np.testing.assert_array_equal(out, half.astype(np.float32))  # R stays R though stored last


def _write_channels(path, channels: dict) -> None:
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, channels) as f:
        f.write(str(path))


def test_an_integer_aov_beside_rgb_is_ignored_and_integer_colour_refused(tmp_path, hdr_image):
    """An engine's EXR may carry an object-id AOV (uint32) beside its beauty R, G, B: the colour is read,
    the AOV ignored; an integer plane among the ones read is refused, named."""
    planes = {c: hdr_image[..., i].copy() for i, c in enumerate("RGB")}
    ids = np.arange(hdr_image.shape[0] * hdr_image.shape[1], dtype=np.uint32).reshape(hdr_image.shape[:2])
    _write_channels(tmp_path / "aov.exr", {**planes, "objectId": ids})
    np.testing.assert_array_equal(envmap.read(tmp_path / "aov.exr"), hdr_image)
    _write_channels(tmp_path / "intr.exr", {**planes, "R": ids})
    with pytest.raises(EnvMapError, match=r"intr.exr: channel R holds uint32 integers, not radiance"):
        envmap.read(tmp_path / "intr.exr")


def test_two_named_layers_are_no_silent_choice(tmp_path, hdr_image):
    planes = {f"{layer}.{c}": hdr_image[..., i].copy() for layer in ("beauty", "albedo") for i, c in enumerate("RGB")}
    _write_channels(tmp_path / "two.exr", planes)
    with pytest.raises(EnvMapError, match=r"several RGB layers \(albedo, beauty\) and none unnamed"):
        envmap.read(tmp_path / "two.exr")
    _write_channels(tmp_path / "three.exr", {**planes, **{c: hdr_image[..., i].copy() for i, c in enumerate("RGB")}})
    np.testing.assert_array_equal(envmap.read(tmp_path / "three.exr"), hdr_image)  # the unnamed layer is read


@pytest.mark.parametrize("rle", [True, False], ids=["rle", "flat"])
def test_hdr_round_trip_within_rgbe_precision(tmp_path, hdr_image, rle):
    imageio.write_hdr(tmp_path / "a.hdr", hdr_image, rle=rle)
    out = envmap.read(tmp_path / "a.hdr")
    # RGBE keeps an 8-bit mantissa relative to the largest channel: with max = m 2^e, m in [0.5, 1), one
    # unit is 2^(e-8) <= 2 max 2^-8, and rounding to nearest errs by at most half a unit: <= 2^-8 of the max
    # (a truncating encoder errs by up to a whole unit, 2^-7 of the max, and fails). float32 adds 1e-6.
    tol = hdr_image.max(axis=-1, keepdims=True) * 2.0**-8 * (1 + 1e-6)
    assert np.all(np.abs(out - hdr_image) <= tol)


def test_hdr_old_style_rle(tmp_path):
    # one scanline of 4 pixels: a pixel then an old-style run (1, 1, 1, 3) repeating it 3 times
    body = bytes([128, 64, 32, 129]) + bytes([1, 1, 1, 3])
    (tmp_path / "old.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 4\n" + body)
    out = imageio.read_hdr(tmp_path / "old.hdr")
    # 128 * 2^(129 - 136) = 1.0, 64 -> 0.5, 32 -> 0.25 (Ward's RGBE decoding)
    np.testing.assert_array_equal(out[0], np.tile([1.0, 0.5, 0.25], (4, 1)))


@pytest.mark.mitsuba
def test_hdr_reader_agrees_with_mitsuba_bitmap(mi):
    from tests.conftest import PROBE_DIR

    ours = envmap.read(PROBE_DIR / "uffizi.hdr")
    theirs = np.array(mi.Bitmap(str(PROBE_DIR / "uffizi.hdr")).convert(
        mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False))
    assert ours.shape == theirs.shape == (128, 256, 3)
    np.testing.assert_allclose(ours, theirs, rtol=1e-6, atol=0)


def test_pfm_round_trip(tmp_path, hdr_image):
    imageio.write_pfm(tmp_path / "a.pfm", hdr_image)
    np.testing.assert_array_equal(envmap.read(tmp_path / "a.pfm"), hdr_image)


@pytest.mark.parametrize(("scale", "dtype"), [(b"-1.0", "<f4"), (b"1.0", ">f4")], ids=["little", "big"])
def test_pfm_reader_on_hand_written_bytes(tmp_path, scale, dtype):
    # PFM stores the bottom row first (a negative scale means little-endian): the 2 x 3 image whose pixel
    # (row r, column c) is (10 r + c, 100 + 10 r + c, 200 + 10 r + c), written out by hand
    pixels = {(r, c): (10 * r + c, 100 + 10 * r + c, 200 + 10 * r + c) for r in range(2) for c in range(3)}
    stored = [pixels[(r, c)] for r in (1, 0) for c in range(3)]  # row 1 (the bottom) first
    body = np.asarray(stored, dtype=dtype).tobytes()
    (tmp_path / "hand.pfm").write_bytes(b"PF\n3 2\n" + scale + b"\n" + body)
    out = imageio.read_pfm(tmp_path / "hand.pfm")
    assert out[0, 0].tolist() == [0.0, 100.0, 200.0] and out[1, 2].tolist() == [12.0, 112.0, 212.0]
    np.testing.assert_array_equal(out, np.asarray([[pixels[(r, c)] for c in range(3)] for r in range(2)]))


@pytest.mark.mitsuba
def test_pfm_writer_and_reader_against_mitsuba_bitmap(mi, tmp_path, hdr_image):
    """Mitsuba's Bitmap as the second opinion in both directions (row 0 at the top, channels R, G, B)."""
    imageio.write_pfm(tmp_path / "ours.pfm", hdr_image)
    np.testing.assert_array_equal(np.array(mi.Bitmap(str(tmp_path / "ours.pfm"))), hdr_image)
    mi.Bitmap(hdr_image).write(str(tmp_path / "theirs.pfm"))
    np.testing.assert_array_equal(imageio.read_pfm(tmp_path / "theirs.pfm"), hdr_image)


@pytest.mark.parametrize("suffix,payload,words", [
    (".exr", b"v/1\x01garbage", "OpenEXR"),
    (".hdr", b"P6\n1 1\n255\n\x00\x00\x00", "Radiance"),
    (".hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 4\n\x10\x10", "truncated"),
    (".pfm", b"PF\n4 4\n-1.0\n\x00\x00", "truncated"),
    (".jpg", b"\xff\xd8", "unsupported"),
])
def test_corrupt_files_give_clear_errors(tmp_path, suffix, payload, words):
    path = tmp_path / f"bad{suffix}"
    path.write_bytes(payload)
    with pytest.raises(EnvMapError, match=words) as err:
        envmap.read(path)
    assert str(path) in str(err.value)


def test_truncated_exr(tmp_path, hdr_image):
    envmap.write(tmp_path / "a.exr", hdr_image)
    data = (tmp_path / "a.exr").read_bytes()
    (tmp_path / "cut.exr").write_bytes(data[: len(data) // 2])
    with pytest.raises(EnvMapError, match="cut.exr"):
        envmap.read(tmp_path / "cut.exr")


def test_invalid_pixels_refused_with_count_and_position(tmp_path, hdr_image):
    bad = hdr_image.copy()
    bad[3, 5, 1] = np.nan
    bad[7, 0, 0] = -1.0
    bad[9, 9, 2] = np.inf
    envmap.write(tmp_path / "bad.exr", bad)
    with pytest.raises(EnvMapError, match=r"3 invalid .* row 3, column 5, channel G") as err:
        envmap.read(tmp_path / "bad.exr")
    assert str(err.value).startswith(f"{tmp_path / 'bad.exr'}: ")  # the message names the file
    with pytest.warns(envmap.SanitizedWarning, match="replaced 3"):
        fixed = envmap.read(tmp_path / "bad.exr", sanitize=True)
    assert np.isfinite(fixed).all() and fixed.min() >= 0 and fixed[3, 5, 1] == 0


def test_too_large_is_refused_before_reading(tmp_path, hdr_image):
    envmap.write(tmp_path / "a.exr", hdr_image)
    with pytest.raises(EnvMapError, match="too large"):
        envmap.read(tmp_path / "a.exr", max_pixels=100)


def test_validate_refuses_by_default_and_checks_the_shape(hdr_image):
    bad = hdr_image.copy()
    bad[0, 0, 0] = -1.0
    with pytest.raises(EnvMapError, match=r"^environment: 1 invalid"):  # refusing is the default
        envmap.validate(bad)
    for shape in [(4, 8), (4, 8, 4)]:
        with pytest.raises(EnvMapError, match=r"expected an \(H, W, 3\) RGB image"):
            envmap.validate(np.ones(shape, np.float32))


def test_three_rows_are_the_least_an_equirect_map_needs(tmp_path):
    envmap.write(tmp_path / "three.exr", np.ones((3, 1, 3), np.float32))
    assert envmap.read(tmp_path / "three.exr").shape == (3, 1, 3)
    for rows in (1, 2):
        envmap.write(tmp_path / f"{rows}.exr", np.ones((rows, 4, 3), np.float32))
        with pytest.raises(EnvMapError, match=f"{rows}.exr: an equirect map needs at least 3 rows, got {rows}"):
            envmap.read(tmp_path / f"{rows}.exr")
