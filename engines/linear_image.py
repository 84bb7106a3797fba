"""An engine's linear image file, read and checked the same way wherever it comes from (an engine run as a
command, `compare --image`, a gate's manifest).

    read(path) -> LinearImage(rgb, coverage)

The format is told by the file's first bytes, not its name: OpenEXR (magic 76 2f 31 01), PFM ("PF"/"Pf")
or Radiance RGBE ("#?"). The radiance must be finite and >= 0 (each refused naming the file, the count and
the first pixel). An OpenEXR alpha channel is the engine's coverage, a pixel covered at alpha >= 0.5, as
iblcheck's own renders write it; a non-finite alpha is refused. Without alpha, `coverage` is None: the
comparison then takes the reference's coverage.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scenes import InputError
from scenes.storage import imageio

EXR_MAGIC = b"\x76\x2f\x31\x01"


@dataclass(frozen=True)
class LinearImage:
    rgb: np.ndarray  # (H, W, 3) float32 linear radiance, row 0 at the top
    coverage: np.ndarray | None  # (H, W) bool from the alpha channel, or None without one
    format: str  # "OpenEXR", "PFM" or "Radiance RGBE"


def sniff(path: Path) -> str:
    """The file's format from its first bytes; InputError naming the file otherwise."""
    try:
        with open(path, "rb") as f:
            head = f.read(4)
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if head == EXR_MAGIC:
        return "OpenEXR"
    if head[:2] in (b"PF", b"Pf"):
        return "PFM"
    if head[:2] == b"#?":
        return "Radiance RGBE"
    raise InputError(f"{path}: neither OpenEXR, PFM nor Radiance RGBE (its first bytes are {head!r}); an engine's "
                     "linear radiance is read from one of those")


def read(path: str | Path) -> LinearImage:
    """Read and check an engine's linear image (module docstring)."""
    path = Path(path)
    kind = sniff(path)
    reader = {"OpenEXR": imageio.read_exr, "PFM": imageio.read_pfm, "Radiance RGBE": imageio.read_hdr}[kind]
    rgb = reader(path)  # EnvMapError (an InputError) naming the file
    bad = ~np.isfinite(rgb)
    if bad.any():
        y, x = np.argwhere(bad.any(axis=-1))[0]
        raise InputError(f"{path}: {int(bad.any(axis=-1).sum())} pixel(s) hold NaN or Inf (first at row {y}, "
                         f"column {x}); an engine's radiance must be finite")
    neg = rgb < 0
    if neg.any():
        y, x = np.argwhere(neg.any(axis=-1))[0]
        raise InputError(f"{path}: {int(neg.any(axis=-1).sum())} pixel(s) hold negative radiance (first at row "
                         f"{y}, column {x}: {rgb[y, x].tolist()}); radiance is >= 0")
    coverage = None
    if kind == "OpenEXR":
        alpha = imageio.read_exr_alpha(path)
        if alpha is not None:
            if not np.isfinite(alpha).all():
                raise InputError(f"{path}: the alpha channel (the engine's coverage) holds NaN or Inf")
            coverage = alpha >= 0.5
    return LinearImage(rgb.astype(np.float32), coverage, kind)
