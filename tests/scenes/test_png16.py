"""The 16-bit PNG reader against two independent encoders: Pillow's (16-bit grey, the one 16-bit mode it
writes) and a forward filter written here from the PNG specification's definitions (section 9.2), one filter
type per scanline, for every colour type."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from scenes.storage import png16
from scenes.storage.errors import InputError


def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def _filtered(line: np.ndarray, above: np.ndarray, bpp: int, kind: int) -> bytes:
    """The specification's forward filter of one scanline of bytes, byte by byte."""
    out = []
    for i, x in enumerate(line.tolist()):
        a = int(line[i - bpp]) if i >= bpp else 0
        b = int(above[i])
        c = int(above[i - bpp]) if i >= bpp else 0
        if kind == 0:
            pred = 0
        elif kind == 1:
            pred = a
        elif kind == 2:
            pred = b
        elif kind == 3:
            pred = (a + b) // 2
        else:
            p = a + b - c
            pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
        out.append((x - pred) % 256)
    return bytes([kind] + out)


def encode(samples: np.ndarray, colour: int, filters: list[int], interlace: int = 0) -> bytes:
    """A 16-bit PNG of `samples` (H, W, C) uint16, scanline y filtered with filters[y % len(filters)]."""
    h, w, c = samples.shape
    lines = samples.astype(">u2").reshape(h, w * c).view(np.uint8)
    above = np.zeros(lines.shape[1], np.uint8)
    raw = b""
    for y in range(h):
        raw += _filtered(lines[y], above, 2 * c, filters[y % len(filters)])
        above = lines[y]
    ihdr = struct.pack(">IIBBBBB", w, h, 16, colour, 0, 0, interlace)
    return png16.SIGNATURE + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", zlib.compress(raw)) + _chunk(b"IEND", b"")


@pytest.mark.parametrize("colour, channels", [(0, 1), (2, 3), (4, 2), (6, 4)])
@pytest.mark.parametrize("filters", [[0], [1], [2], [3], [4], [0, 1, 2, 3, 4]])
def test_every_filter_and_colour_type_round_trips(tmp_path, colour, channels, filters):
    samples = np.random.default_rng(colour * 10 + len(filters)).integers(0, 65536, (7, 5, channels), np.uint16)
    samples[0, 0] = 65535  # wraps in every lane
    path = tmp_path / "a.png"
    path.write_bytes(encode(samples, colour, filters))
    assert png16.bit_depth(path) == 16
    np.testing.assert_array_equal(png16.read(path), samples)


def test_pillows_own_16_bit_grey_png_reads_alike(tmp_path):
    """Pillow writes (and reads, correctly) 16-bit grey, with its own filter choices and zlib settings."""
    values = np.random.default_rng(3).integers(0, 65536, (33, 47), np.uint16)
    Image.fromarray(values).save(tmp_path / "g.png")
    assert png16.bit_depth(tmp_path / "g.png") == 16
    np.testing.assert_array_equal(png16.read(tmp_path / "g.png")[..., 0], values)
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "g.png")), values)


def test_pillow_alone_loses_the_low_byte_of_16_bit_rgb(tmp_path):
    """Why this reader exists (the negative control): Pillow reads the same RGB file as 8 bits a channel."""
    samples = np.full((4, 4, 3), 0x12AB, np.uint16)
    (tmp_path / "c.png").write_bytes(encode(samples, 2, [0]))
    assert np.asarray(Image.open(tmp_path / "c.png")).dtype == np.uint8
    assert png16.read(tmp_path / "c.png")[0, 0, 0] == 0x12AB


@pytest.mark.parametrize("damage, words", [
    (lambda b: b[:-20], "cut short"),
    (lambda b: b[:40] + bytes([b[40] ^ 1]) + b[41:], "fails its CRC"),
    (lambda b: b"GIF89a" + b[6:], "not a PNG file"),
])
def test_a_damaged_file_is_refused_naming_it(tmp_path, damage, words):
    good = encode(np.zeros((3, 3, 3), np.uint16), 2, [0])
    (tmp_path / "d.png").write_bytes(damage(good))
    with pytest.raises(InputError, match=rf"d.png: .*{words}"):
        png16.read(tmp_path / "d.png")


def test_an_interlaced_file_is_refused_by_name(tmp_path):
    (tmp_path / "i.png").write_bytes(encode(np.zeros((3, 3, 3), np.uint16), 2, [0], interlace=1))
    with pytest.raises(InputError, match="interlaced"):
        png16.read(tmp_path / "i.png")
