"""HDR environment maps: read, write, validate, and look up radiance exactly as Mitsuba does.

An environment map is a float32 array (H, W, 3) of linear radiance in Mitsuba's equirect
convention (see `scenes.environment.directions`). `lookup` reproduces Mitsuba's `envmap` emitter's bilinear
interpolation to float precision (tested against Mitsuba itself), so every conversion that
feeds either renderer (cube faces, SH projection, the quadrature reference) sees the same
radiance Mitsuba's path tracer sees.
"""

from __future__ import annotations

import hashlib
import warnings
from pathlib import Path

import numpy as np

from scenes.environment.directions import direction_to_uv, to_environment_frame
from scenes.storage import imageio
from scenes.storage.errors import EnvMapError
from scenes.storage.files import input_problem, short_repr

READERS = {".exr": imageio.read_exr, ".hdr": imageio.read_hdr, ".rgbe": imageio.read_hdr, ".pfm": imageio.read_pfm}
#: the largest radiance a map may hold (after environment.scale): both renderers sum many texels and
#: samples of it in float32 (Mitsuba's envmap CDF, the film, the SH projection), which overflow near
#: the float32 maximum; 1e20 leaves them 1e18 of headroom (a sun is 1e5 ... 1e9 times the sky)
MAX_RADIANCE = 1e20
#: the fewest rows a map may have. Rows are samples from pole to pole (row = v (H - 1)), which 2 rows
#: satisfy, but Mitsuba 3's `envmap` reads a 2-row map as if its last row were doubled (row = 2 v: the
#: south half of the sphere takes the last row's value, measured in tests/scenes/test_tiny_maps.py),
#: while it agrees with `lookup` to float precision from 3 rows on and for any width.
MIN_ROWS = 3


class SanitizedWarning(UserWarning):
    """Emitted when `read(..., sanitize=True)` replaced invalid pixels."""


def read(path: str | Path, sanitize: bool = False, max_pixels: int | None = None) -> np.ndarray:
    """Read an HDR map (.exr, .hdr, .pfm) as float32 (H, W, 3) linear RGB, row 0 at the top.

    NaN, Inf and negative values are refused with their count and first position; with
    `sanitize=True` they are replaced by 0 and a `SanitizedWarning` says how many.
    """
    path = Path(path)
    reader = READERS.get(path.suffix.lower())
    if reader is None:
        raise EnvMapError(f"{path}: unsupported environment format {short_repr(path.suffix)} "
                          "(use .exr, .hdr or .pfm)")
    problem = input_problem(path)
    if problem:
        raise EnvMapError(f"{path}: environment map {problem}")
    rgb = reader(path, max_pixels=max_pixels)
    return validate(rgb, str(path), sanitize=sanitize)


def validate(rgb: np.ndarray, name: str = "environment", sanitize: bool = False) -> np.ndarray:
    """Check (H, W, 3) radiance for NaN / Inf / negatives; refuse or (sanitize) zero them."""
    rgb = np.asarray(rgb, dtype=np.float32)
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise EnvMapError(f"{name}: expected an (H, W, 3) RGB image, got shape {rgb.shape}")
    if rgb.shape[0] < MIN_ROWS:
        raise EnvMapError(f"{name}: an equirect map needs at least {MIN_ROWS} rows, got {rgb.shape[0]} (Mitsuba "
                          "reads a 2-row map differently from its own lookup: the renderers would not agree)")
    bad = ~np.isfinite(rgb) | (rgb < 0)
    count = int(bad.sum())
    if count == 0:
        return rgb
    if not sanitize:
        r, c, ch = (int(i) for i in np.argwhere(bad)[0])
        raise EnvMapError(
            f"{name}: {count} invalid radiance values (NaN, Inf or negative); first at row {r}, "
            f"column {c}, channel {'RGB'[ch]} = {float(rgb[r, c, ch])!r}; pass --sanitize to replace them with 0"
        )
    rgb = np.where(bad, np.float32(0.0), rgb)
    warnings.warn(f"{name}: replaced {count} invalid radiance values (NaN, Inf or negative) with 0",
                  SanitizedWarning, stacklevel=2)
    return rgb


def check_peak(rgb: np.ndarray, name: str, scale: float = 1.0) -> None:
    """Refuse radiance above MAX_RADIANCE (after the scale), which would overflow in the renderers."""
    peak = float(np.max(rgb)) if rgb.size else 0.0
    if peak > float(np.float32(MAX_RADIANCE)):  # 1e20 itself, as float32 stores it, is accepted
        times = "" if scale == 1.0 else f" (environment.scale = {scale:g} included)"
        raise EnvMapError(f"{name}: peak radiance {peak:.3g}{times} is above {MAX_RADIANCE:g}, the most both "
                          "renderers carry without overflowing float32; lower environment.scale")


def write(path: str | Path, rgb: np.ndarray) -> None:
    """Write (H, W, 3) float32 radiance as OpenEXR (the extension must be .exr)."""
    path = Path(path)
    if path.suffix.lower() != ".exr":
        raise EnvMapError(f"{path}: environment maps are written as .exr")
    imageio.write_exr(path, np.asarray(rgb, dtype=np.float32))


def lookup(env: np.ndarray, directions: np.ndarray, rotation_deg: float = 0.0) -> np.ndarray:
    """Radiance (..., 3) seen along world `directions` (..., 3), bilinear exactly as Mitsuba.

    `rotation_deg` turns the map about +Y like Mitsuba's `to_world = rotate([0, 1, 0], deg)`.
    Columns wrap (col = u W - 0.5); rows are align-corners (row = v (H - 1)).
    """
    env = np.asarray(env)
    h, w = env.shape[:2]
    u, v = direction_to_uv(to_environment_frame(directions, rotation_deg))
    col = u * w - 0.5
    row = v * (h - 1)
    c0 = np.floor(col)
    fc = (col - c0)[..., None]
    c0 = c0.astype(np.int64) % w
    c1 = (c0 + 1) % w
    r0 = np.clip(np.floor(row).astype(np.int64), 0, h - 2)
    fr = (row - r0)[..., None]
    top = env[r0, c0] * (1.0 - fc) + env[r0, c1] * fc
    bottom = env[r0 + 1, c0] * (1.0 - fc) + env[r0 + 1, c1] * fc
    return (top * (1.0 - fr) + bottom * fr).astype(np.float32)


def file_digest(path: str | Path) -> str:
    """SHA-256 of a file's bytes (for cache keys)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()
