"""16-bit PNG files, decoded here because Pillow reads a 16-bit RGB or RGBA PNG as 8 bits a channel (it has no
48- or 64-bit mode) and a 16-bit grey + alpha one likewise, silently dropping the low byte an engine wrote.

    bit_depth(path) -> int          the IHDR's bits per channel (1, 2, 4, 8 or 16)
    read(path) -> ndarray           (H, W, C) uint16, C = 1 grey, 2 grey + alpha, 3 RGB, 4 RGBA; row 0 at the top

The format is the PNG specification's (ISO/IEC 15948, W3C PNG 2nd edition): the 8-byte signature, then chunks
(a 4-byte big-endian length, a 4-byte type, the data, a CRC-32 of type and data); IHDR first, the zlib stream
split over IDAT chunks, IEND last. Each scanline is one filter-type byte then the filtered bytes; filters
predict a byte from a (the byte one pixel to the left, bpp bytes back), b (the byte above) and c (above-left),
all 0 outside the image (section 9.2):

    0 None: x      1 Sub: x + a      2 Up: x + b      3 Average: x + floor((a + b) / 2)      4 Paeth: x + P(a, b, c)

modulo 256, P being the one of a, b, c nearest to a + b - c (ties to a, then b). Samples are big-endian.
Only what 16-bit images need is read: interlaced (Adam7) files and palettes (never 16-bit) are refused by name.
Every problem is an InputError naming the file.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from scenes.storage.errors import InputError

SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: channels per colour type (3, indexed colour, is never 16-bit)
CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}
#: the largest decompressed image read (an 8K RGBA 16-bit frame is 265 MB)
MAX_BYTES = 1 << 29


def _chunks(path: Path, data: bytes):
    if not data.startswith(SIGNATURE):
        raise InputError(f"{path}: not a PNG file (its first bytes are not the PNG signature)")
    pos = len(SIGNATURE)
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        crc = data[pos + 8 + length:pos + 12 + length]
        if len(body) != length or len(crc) != 4:
            raise InputError(f"{path}: PNG chunk {kind!r} is cut short (a truncated file)")
        if zlib.crc32(kind + body) != struct.unpack(">I", crc)[0]:
            raise InputError(f"{path}: PNG chunk {kind!r} fails its CRC (a corrupt file)")
        yield kind, body
        if kind == b"IEND":
            return
        pos += 12 + length
    raise InputError(f"{path}: PNG file ends before its IEND chunk (a truncated file)")


def _header(path: Path, body: bytes) -> tuple[int, int, int, int, int]:
    if len(body) != 13:
        raise InputError(f"{path}: PNG IHDR of {len(body)} bytes; the format has 13")
    width, height, depth, colour, compression, filtering, interlace = struct.unpack(">IIBBBBB", body)
    if width == 0 or height == 0 or compression != 0 or filtering != 0:
        raise InputError(f"{path}: PNG IHDR width {width}, height {height}, compression {compression}, filter "
                         f"method {filtering}: not a valid PNG")
    return width, height, depth, colour, interlace


def bit_depth(path: str | Path) -> int:
    """Bits per channel from the IHDR (the first chunk, at a fixed offset); InputError for a non-PNG."""
    path = Path(path)
    with open(path, "rb") as f:
        head = f.read(33)
    if not head.startswith(SIGNATURE) or head[12:16] != b"IHDR" or len(head) < 33:
        raise InputError(f"{path}: not a PNG file (no PNG signature and IHDR)")
    return head[24]


def _paeth(a: int, b: int, c: int) -> int:
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    return a if pa <= pb and pa <= pc else (b if pb <= pc else c)


def unfilter(rows: np.ndarray, bpp: int, path: Path) -> np.ndarray:
    """Undo the scanline filters of `rows` ((H, 1 + stride) uint8: filter byte, then the line) -> (H, stride).
    None, Sub and Up are vectorised (Sub is a running sum per byte lane, wrapping at 256); Average and Paeth
    depend on the byte just reconstructed to their left, so they run byte by byte."""
    height, stride = rows.shape[0], rows.shape[1] - 1
    out = np.zeros((height, stride), np.uint8)
    prev = np.zeros(stride, np.uint8)
    for y in range(height):
        kind, line = int(rows[y, 0]), rows[y, 1:]
        if kind == 0:
            cur = line.copy()
        elif kind == 1:
            cur = np.cumsum(line.reshape(-1, bpp), axis=0, dtype=np.uint8).reshape(-1)
        elif kind == 2:
            cur = line + prev
        elif kind in (3, 4):
            x, b, cur_b = line.tolist(), prev.tolist(), [0] * stride
            for i in range(stride):
                left = cur_b[i - bpp] if i >= bpp else 0
                if kind == 3:
                    cur_b[i] = (x[i] + ((left + b[i]) >> 1)) & 0xFF
                else:
                    corner = b[i - bpp] if i >= bpp else 0
                    cur_b[i] = (x[i] + _paeth(left, b[i], corner)) & 0xFF
            cur = np.array(cur_b, np.uint8)
        else:
            raise InputError(f"{path}: PNG scanline {y} has filter type {kind}; the format has 0 to 4")
        out[y] = cur
        prev = cur
    return out


def read(path: str | Path) -> np.ndarray:
    """The image's samples, (H, W, C) uint16 (module docstring). 8-bit and lower files are left to Pillow:
    this reads 16-bit files only."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    header, idat = None, []
    for kind, body in _chunks(path, data):
        if header is None:
            if kind != b"IHDR":
                raise InputError(f"{path}: PNG's first chunk is {kind!r}, not IHDR")
            header = _header(path, body)
        elif kind == b"IDAT":
            idat.append(body)
    width, height, depth, colour, interlace = header
    if depth != 16 or colour not in CHANNELS:
        raise InputError(f"{path}: PNG of bit depth {depth}, colour type {colour}; this reader is for 16-bit grey, "
                         "grey + alpha, RGB and RGBA")
    if interlace != 0:
        raise InputError(f"{path}: an interlaced (Adam7) 16-bit PNG is not read; save it without interlacing")
    channels = CHANNELS[colour]
    bpp = 2 * channels
    expected = height * (1 + width * bpp)
    if expected > MAX_BYTES:
        raise InputError(f"{path}: a {width} x {height} 16-bit PNG ({expected} bytes decoded) exceeds the "
                         f"{MAX_BYTES}-byte limit")
    try:
        raw = zlib.decompressobj().decompress(b"".join(idat), expected + 1)
    except zlib.error as exc:
        raise InputError(f"{path}: PNG image data does not decompress ({exc})") from None
    if len(raw) != expected:
        raise InputError(f"{path}: PNG image data holds {len(raw)} bytes where {width} x {height} pixels need "
                         f"{expected}")
    lines = unfilter(np.frombuffer(raw, np.uint8).reshape(height, 1 + width * bpp), bpp, path)
    return lines.view(">u2").reshape(height, width, channels).astype(np.uint16)
