"""Readers and writers for HDR image files: OpenEXR, Radiance RGBE (.hdr) and PFM.

Every reader returns float32 (H, W, 3) linear RGB with row 0 at the top and raises
`EnvMapError` naming the file for anything it cannot read. Image sizes are checked
against `max_pixels` from the header, before pixel memory is allocated.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from .errors import EnvMapError

#: Largest image accepted, in pixels (2^28 = 268 M pixels = 3 GiB of float32 RGB).
MAX_PIXELS = 1 << 28


def check_size(path: Path, width: int, height: int, max_pixels: int | None = None) -> None:
    """Refuse sizes that are empty or would not fit in memory, before anything is allocated."""
    limit = MAX_PIXELS if max_pixels is None else max_pixels
    if width <= 0 or height <= 0:
        raise EnvMapError(f"{path}: image size {width}x{height} is empty")
    if width * height > limit:
        raise EnvMapError(
            f"{path}: image of {width}x{height} = {width * height} pixels is too large "
            f"(limit {limit} pixels, {limit * 12 / 2**30:.1f} GiB as float32 RGB); downsample it first"
        )


# --------------------------------------------------------------------------- OpenEXR


def read_exr(path: Path, max_pixels: int | None = None) -> np.ndarray:
    """Read R, G, B channels by name (any order, half or float); alpha and others ignored.

    A single-channel file (Y or any one channel) is read as grey.
    """
    import OpenEXR

    try:
        with OpenEXR.File(str(path), header_only=True) as f:
            # copy out now: the binding empties the header dict when the file closes
            lo, hi = (np.array(x) for x in f.header()["dataWindow"])
    except Exception as exc:  # the binding raises RuntimeError/ValueError for corrupt files
        raise EnvMapError(f"{path}: not a readable OpenEXR file ({exc})") from None
    width, height = int(hi[0] - lo[0] + 1), int(hi[1] - lo[1] + 1)
    check_size(path, width, height, max_pixels)
    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            channels = {name: np.array(ch.pixels) for name, ch in f.channels().items()}
    except Exception as exc:
        raise EnvMapError(f"{path}: corrupt or truncated OpenEXR data ({exc})") from None
    # Channels may live in a layer ("diffuse.R"): match on the last name component.
    by_short = {name.rsplit(".", 1)[-1].upper(): px for name, px in channels.items()}
    if all(c in by_short for c in "RGB"):
        planes = [by_short[c] for c in "RGB"]
    elif len(channels) == 1 or "Y" in by_short:
        grey = by_short.get("Y", next(iter(channels.values())))
        planes = [grey, grey, grey]
    else:
        raise EnvMapError(
            f"{path}: needs R, G and B channels (or a single grey channel); found {sorted(channels)}"
        )
    out = np.stack([np.asarray(p, dtype=np.float32) for p in planes], axis=-1)
    if out.ndim != 3 or out.shape[:2] != (height, width):
        raise EnvMapError(f"{path}: channel sizes {out.shape} disagree with the data window {width}x{height}")
    return out


def write_exr(path: Path, rgb: np.ndarray, alpha: np.ndarray | None = None, half: bool = False) -> None:
    """Write float32 (or half) R, G, B[, A] channels, ZIP-compressed, scanline order top first."""
    import OpenEXR

    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"write_exr expects (H, W, 3), got {rgb.shape}")
    dtype = np.float16 if half else np.float32
    channels = {c: np.ascontiguousarray(rgb[..., i], dtype=dtype) for i, c in enumerate("RGB")}
    if alpha is not None:
        channels["A"] = np.ascontiguousarray(alpha, dtype=dtype)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    tmp = Path(f"{path}.tmp{os.getpid()}")
    with OpenEXR.File(header, channels) as f:
        f.write(str(tmp))
    os.replace(tmp, path)


# --------------------------------------------------------------------------- Radiance RGBE

_RES_RE = re.compile(rb"^([-+])Y\s+(\d+)\s+([-+])X\s+(\d+)\s*$")


def read_hdr(path: Path, max_pixels: int | None = None) -> np.ndarray:
    """Read a Radiance RGBE file: flat, new-style RLE and old-style RLE scanlines.

    Decoding follows Greg Ward's reference: value = mantissa * 2^(exponent - 136), 0 when the
    exponent byte is 0. Only the standard `-Y H +X W` (top row first) and `+Y H +X W` orientations.
    """
    data = Path(path).read_bytes()
    if not (data.startswith(b"#?RADIANCE") or data.startswith(b"#?RGBE")):
        raise EnvMapError(f"{path}: not a Radiance .hdr file (missing '#?RADIANCE' signature)")
    pos = 0
    fmt = None
    while True:
        end = data.find(b"\n", pos)
        if end < 0:
            raise EnvMapError(f"{path}: truncated header (no blank line before the resolution)")
        line = data[pos:end].strip()
        pos = end + 1
        if not line:
            break
        if line.startswith(b"FORMAT="):
            fmt = line[7:].strip()
    if fmt not in (None, b"32-bit_rle_rgbe"):
        raise EnvMapError(f"{path}: FORMAT={fmt.decode(errors='replace')} is not supported (only 32-bit_rle_rgbe)")
    end = data.find(b"\n", pos)
    m = _RES_RE.match(data[pos : end if end >= 0 else len(data)])
    if not m:
        raise EnvMapError(f"{path}: unsupported or corrupt resolution line {data[pos:end][:40]!r}")
    height, width = int(m.group(2)), int(m.group(4))
    if m.group(3) != b"+":
        raise EnvMapError(f"{path}: mirrored -X orientation is not supported")
    check_size(path, width, height, max_pixels)
    pos = end + 1
    rgbe = np.empty((height, width, 4), dtype=np.uint8)
    buf = memoryview(data)
    n = len(data)
    for y in range(height):
        pos = _read_scanline(buf, n, pos, rgbe[y], width, path, y)
    if m.group(1) == b"+":  # bottom row first in the file
        rgbe = rgbe[::-1]
    return _rgbe_to_float(rgbe)


def _read_scanline(buf, n: int, pos: int, out: np.ndarray, width: int, path, y: int) -> int:
    def need(k: int) -> None:
        if pos + k > n:
            raise EnvMapError(f"{path}: truncated pixel data at scanline {y}")

    need(4)
    b0, b1, b2, b3 = buf[pos], buf[pos + 1], buf[pos + 2], buf[pos + 3]
    if 8 <= width < 32768 and b0 == 2 and b1 == 2 and (b2 & 0x80) == 0:
        # new-style RLE: four components stored one after the other, each run-length coded
        if (b2 << 8 | b3) != width:
            raise EnvMapError(f"{path}: corrupt RLE scanline {y} (length {(b2 << 8 | b3)} != width {width})")
        pos += 4
        for c in range(4):
            x = 0
            while x < width:
                need(1)
                count = buf[pos]
                pos += 1
                if count > 128:  # a run
                    count -= 128
                    need(1)
                    if x + count > width:
                        raise EnvMapError(f"{path}: corrupt RLE run in scanline {y}")
                    out[x : x + count, c] = buf[pos]
                    pos += 1
                else:  # literal bytes
                    if count == 0 or x + count > width:
                        raise EnvMapError(f"{path}: corrupt RLE data in scanline {y}")
                    need(count)
                    out[x : x + count, c] = np.frombuffer(buf[pos : pos + count], dtype=np.uint8)
                    pos += count
                x += count
        return pos
    # flat pixels, possibly with old-style runs (1, 1, 1, count) repeating the previous pixel
    x = 0
    shift = 0
    while x < width:
        need(4)
        px = buf[pos : pos + 4]
        pos += 4
        if px[0] == 1 and px[1] == 1 and px[2] == 1:
            if x == 0:
                raise EnvMapError(f"{path}: corrupt old-style run at the start of scanline {y}")
            count = px[3] << shift
            if x + count > width:
                raise EnvMapError(f"{path}: corrupt old-style run in scanline {y}")
            out[x : x + count] = out[x - 1]
            x += count
            shift += 8
        else:
            out[x] = np.frombuffer(px, dtype=np.uint8)
            x += 1
            shift = 0
    return pos


def _rgbe_to_float(rgbe: np.ndarray) -> np.ndarray:
    e = rgbe[..., 3].astype(np.int32)
    scale = np.where(e == 0, 0.0, np.ldexp(1.0, e - 136)).astype(np.float64)
    return (rgbe[..., :3].astype(np.float64) * scale[..., None]).astype(np.float32)


def float_to_rgbe(rgb: np.ndarray) -> np.ndarray:
    """Encode non-negative linear RGB as RGBE bytes (H, W, 4), rounding to nearest."""
    rgb = np.asarray(rgb, dtype=np.float64)
    vmax = rgb.max(axis=-1)
    mant, exp = np.frexp(vmax)  # vmax = mant * 2^exp, mant in [0.5, 1)
    out = np.zeros(rgb.shape[:-1] + (4,), dtype=np.uint8)
    ok = vmax > 1e-38
    scale = np.where(ok, np.ldexp(1.0, 8 - exp), 0.0)
    out[..., :3] = np.clip(np.floor(rgb * scale[..., None] + 0.5), 0, 255).astype(np.uint8)
    out[..., 3] = np.where(ok, exp + 128, 0).astype(np.uint8)
    return out


def write_hdr(path: Path, rgb: np.ndarray, rle: bool = True) -> None:
    """Write a Radiance .hdr (top row first), with new-style RLE when `rle` is true."""
    rgbe = float_to_rgbe(rgb)
    h, w = rgbe.shape[:2]
    chunks = [b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n", f"-Y {h} +X {w}\n".encode()]
    for y in range(h):
        if rle and 8 <= w < 32768:
            chunks.append(bytes([2, 2, w >> 8, w & 0xFF]))
            for c in range(4):
                chunks.append(_rle_encode(rgbe[y, :, c]))
        else:
            chunks.append(rgbe[y].tobytes())
    Path(path).write_bytes(b"".join(chunks))


def _rle_encode(row: np.ndarray) -> bytes:
    out = bytearray()
    i, n = 0, len(row)
    while i < n:
        run = 1
        while i + run < n and run < 127 and row[i + run] == row[i]:
            run += 1
        if run >= 3:
            out += bytes([128 + run, int(row[i])])
            i += run
            continue
        j = i
        while j < n and j - i < 128 and not (j + 2 < n and row[j] == row[j + 1] == row[j + 2]):
            j += 1
        out += bytes([j - i]) + row[i:j].tobytes()
        i = j
    return bytes(out)


# --------------------------------------------------------------------------- PFM


def read_pfm(path: Path, max_pixels: int | None = None) -> np.ndarray:
    """Read a Portable Float Map ('PF' colour or 'Pf' grey); the file stores the bottom row first."""
    data = Path(path).read_bytes()
    tokens = data.split(maxsplit=4)
    if len(tokens) < 5 or tokens[0] not in (b"PF", b"Pf"):
        raise EnvMapError(f"{path}: not a PFM file (expected 'PF' or 'Pf' header)")
    try:
        width, height, scale = int(tokens[1]), int(tokens[2]), float(tokens[3])
    except ValueError:
        raise EnvMapError(f"{path}: corrupt PFM header {data[:40]!r}") from None
    check_size(path, width, height, max_pixels)
    ch = 3 if tokens[0] == b"PF" else 1
    # header is three whitespace-separated lines; pixel data starts after the third newline
    offset = 0
    for _ in range(3):
        offset = data.index(b"\n", offset) + 1
    count = width * height * ch
    if len(data) - offset < 4 * count:
        raise EnvMapError(f"{path}: truncated PFM data ({len(data) - offset} bytes, need {4 * count})")
    dtype = "<f4" if scale < 0 else ">f4"
    arr = np.frombuffer(data, dtype=dtype, count=count, offset=offset).reshape(height, width, ch)
    arr = arr[::-1].astype(np.float32)
    return np.repeat(arr, 3, axis=2) if ch == 1 else arr


def write_pfm(path: Path, rgb: np.ndarray) -> None:
    rgb = np.asarray(rgb, dtype="<f4")
    h, w = rgb.shape[:2]
    Path(path).write_bytes(f"PF\n{w} {h}\n-1.0\n".encode() + rgb[::-1].tobytes())
