"""Readers and writers for HDR image files: OpenEXR, Radiance RGBE (.hdr) and PFM.

Every reader returns float32 (H, W, 3) linear RGB with row 0 at the top and raises
`EnvMapError` naming the file for anything it cannot read. Image sizes are checked
against `max_pixels` from the header, before pixel memory is allocated.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import OpenEXR

from scenes.storage.errors import EnvMapError
from scenes.storage.files import atomic_output

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
    """Read the R, G, B channels by name (any order, half or float; alpha and other channels, integer AOVs
    included, ignored), or a luminance channel Y as grey. Anything else is refused, naming what the file
    holds: an alpha-only file is no white map, a crop of a larger display window no whole equirect map, and
    several layers or parts are no choice to make silently."""
    try:
        with OpenEXR.File(str(path), header_only=True) as f:
            # copy out now: the binding empties the header dict when the file closes
            header = f.header()
            data_window = tuple(tuple(int(v) for v in x) for x in header["dataWindow"])
            display_window = tuple(tuple(int(v) for v in x) for x in header["displayWindow"])
            parts = [p.name() for p in f.parts]
    except Exception:  # the binding raises RuntimeError/ValueError for corrupt files
        raise EnvMapError(f"{path}: not a readable OpenEXR file (bad signature or corrupt header)") from None
    (x0, y0), (x1, y1) = data_window
    width, height = x1 - x0 + 1, y1 - y0 + 1
    check_size(path, width, height, max_pixels)
    if len(parts) > 1:
        raise EnvMapError(f"{path}: a multi-part OpenEXR file ({len(parts)} parts: {', '.join(parts[:6])}); "
                          "an environment map is one RGB image: save the part you mean on its own")
    if data_window != display_window:
        raise EnvMapError(f"{path}: the data window {data_window} covers only part of the display window "
                          f"{display_window}; an equirect map must fill its whole image")
    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            channels = {name: np.array(ch.pixels) for name, ch in f.channels().items()}
    except Exception:
        raise EnvMapError(f"{path}: corrupt or truncated OpenEXR pixel data") from None
    planes = _exr_colour_planes(path, channels)
    out = np.stack([np.asarray(p, dtype=np.float32) for p in planes], axis=-1)
    if out.ndim != 3 or out.shape[:2] != (height, width):
        raise EnvMapError(f"{path}: channel sizes {out.shape} disagree with the data window {width}x{height}")
    return out


#: what a channel name says it holds, for errors about files without colour
_CHANNEL_KINDS = {"R": "red", "G": "green", "B": "blue", "A": "alpha", "Z": "depth", "ZBACK": "depth",
                  "Y": "luminance", "RY": "chroma", "BY": "chroma"}


def _exr_colour_planes(path: Path, channels: dict[str, np.ndarray]) -> list[np.ndarray]:
    """[R, G, B] planes of one layer, or [Y, Y, Y]; EnvMapError naming the channels otherwise."""
    layers: dict[str, dict[str, np.ndarray]] = {}
    for name, px in channels.items():
        layer, _, short = name.rpartition(".")
        layers.setdefault(layer, {})[short.upper()] = px
    held = ", ".join(f"{n} ({_CHANNEL_KINDS.get(n.rpartition('.')[2].upper(), 'unknown')})" for n in sorted(channels))

    def radiance(layer: str, names: str) -> list[np.ndarray]:
        # only the planes read must hold radiance: an integer AOV beside them (an object id) is ignored
        for c in names:
            if layers[layer][c].dtype.kind != "f":
                full = f"{layer}.{c}" if layer else c
                raise EnvMapError(f"{path}: channel {full} holds {layers[layer][c].dtype.name} integers, not "
                                  "radiance: the R, G, B (or Y) channels read must be half or float")
        return [layers[layer][c] for c in names]

    rgb = [layer for layer, chans in layers.items() if all(c in chans for c in "RGB")]
    if "" in rgb:
        rgb = [""]
    if len(rgb) > 1:
        raise EnvMapError(f"{path}: several RGB layers ({', '.join(sorted(rgb))}) and none unnamed; iblcheck reads "
                          "one image: save the layer you mean on its own, or as the unnamed R, G, B")
    if rgb:
        return radiance(rgb[0], "RGB")
    grey = [layer for layer, chans in layers.items() if "Y" in chans]
    if len(grey) == 1 and not ({"RY", "BY"} & set(layers[grey[0]])):
        y = radiance(grey[0], "Y")[0]
        return [y, y, y]
    if grey:
        raise EnvMapError(f"{path}: a luminance/chroma OpenEXR file (channels {held}); save it as RGB")
    raise EnvMapError(f"{path}: holds no colour radiance: its channels are {held}; iblcheck reads R, G and B "
                      "channels (or one luminance channel Y)")


def read_exr_alpha(path: Path) -> np.ndarray | None:
    """The A channel of an OpenEXR file that `read_exr` reads (float32 (H, W)), or None when it has none.
    An engine's alpha is its coverage: iblcheck's own renders write it that way (`write_exr(..., alpha)`)."""
    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            channels = {name: np.array(ch.pixels) for name, ch in f.channels().items()}
    except Exception:
        raise EnvMapError(f"{path}: corrupt or truncated OpenEXR pixel data") from None
    alpha = channels.get("A")
    return None if alpha is None else np.asarray(alpha, dtype=np.float32)


def write_exr(path: Path, rgb: np.ndarray, alpha: np.ndarray | None = None, half: bool = False) -> None:
    """Write float32 (or half) R, G, B[, A] channels, ZIP-compressed, scanline order top first."""
    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"write_exr expects (H, W, 3), got {rgb.shape}")
    dtype = np.float16 if half else np.float32
    channels = {c: np.ascontiguousarray(rgb[..., i], dtype=dtype) for i, c in enumerate("RGB")}
    if alpha is not None:
        channels["A"] = np.ascontiguousarray(alpha, dtype=dtype)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with atomic_output(path) as tmp, OpenEXR.File(header, channels) as f:
        f.write(str(tmp))


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


_PFM_HEADER = re.compile(rb"^(PF|Pf)\s+(\S+)\s+(\S+)\s+(\S+)\s")


def read_pfm(path: Path, max_pixels: int | None = None) -> np.ndarray:
    """Read a Portable Float Map ('PF' colour or 'Pf' grey); the file stores the bottom row first.

    The header is three whitespace-separated values after the signature, then one whitespace
    character; the scale's sign gives the byte order (negative: little-endian). A scale of 0 (or not
    a finite number) says nothing about the byte order: the file is refused, not read as black."""
    data = Path(path).read_bytes()
    m = _PFM_HEADER.match(data[:256])
    if not m:
        raise EnvMapError(f"{path}: not a PFM file (expected a 'PF' or 'Pf' header with width, height and scale)")
    try:
        width, height, scale = int(m.group(2)), int(m.group(3)), float(m.group(4))
    except ValueError:
        raise EnvMapError(f"{path}: corrupt PFM header {data[:m.end()][:40]!r}") from None
    if not np.isfinite(scale) or scale == 0:
        raise EnvMapError(f"{path}: PFM scale {m.group(4).decode(errors='replace')!r} must be a non-zero number "
                          "(its sign gives the byte order: negative for little-endian)")
    check_size(path, width, height, max_pixels)
    ch = 3 if m.group(1) == b"PF" else 1
    offset = m.end()
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
