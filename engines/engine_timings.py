"""The frame timings an external engine may write beside its image, and how iblcheck reports them.

The JSON file (every key optional):

    {"engine": "three.js", "version": "0.181.0",
     "frame_ms": [1.9, 2.1, ...],     one entry per timed frame, after the engine's own warm-up
     "precompute_ms": 41.0,           once per scene: prefiltering, table builds (three.js' PMREM, say)
     "notes": "SwiftShader (CPU)"}    what the milliseconds are, in the engine's words

They become a Render's timings like iblcheck's own: `draw` and `total` the median frame time, `draw_p90` its
90th percentile, `precompute`. A number that is not finite and >= 0, or a key of the wrong kind, is refused
naming the file and key: a frame time is a claim the reports print. Other keys are the engine's own and are
left unread (the bundled engines add load and first-frame times), except one that looks like a misspelt key
the file lacks (`frame_msec` holding a list, without `frame_ms`): that is refused, since its numbers would
silently vanish.
"""

from __future__ import annotations

import difflib
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scenes import InputError
from scenes.storage.files import read_input


@dataclass(frozen=True)
class EngineTimings:
    engine: str = ""
    version: str = ""
    frame_ms: tuple[float, ...] = ()
    precompute_ms: float | None = None
    notes: str = ""

    def as_render_timings(self) -> dict[str, float]:
        """Render.timings: `draw` = `total` = the median frame, `draw_p90`, `precompute` (those given)."""
        out: dict[str, float] = {}
        if self.frame_ms:
            median = float(np.median(self.frame_ms))
            out.update(draw=median, total=median, draw_p90=float(np.percentile(self.frame_ms, 90)))
        if self.precompute_ms is not None:
            out["precompute"] = float(self.precompute_ms)
        return out


def _ms(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
        raise InputError(f"{where} = {value!r}: must be a finite number of milliseconds >= 0")
    return float(value)


def _text(tree: dict, key: str, path: Path) -> str:
    value = tree.get(key, "")
    if not isinstance(value, str):
        raise InputError(f"{path}: {key} = {value!r}: must be a string")
    return value[:200]


#: the largest timings file read (a few thousand frame times fit many times over)
MAX_BYTES = 1 << 20


#: the keys read; any other key is the engine's own
KEYS = ("engine", "version", "frame_ms", "precompute_ms", "notes")
#: how close (difflib's ratio) an unknown key must be to a missing known one to count as its misspelling
MISSPELT_RATIO = 0.75


#: the kind of value each read key holds: a misspelling holds the same kind
KINDS = {"engine": str, "version": str, "frame_ms": list, "precompute_ms": (int, float), "notes": str}


def _check_keys(tree: dict, where: str) -> None:
    """Refuse a key that reads like a misspelling of a read key the file lacks: close to it (difflib), holding
    the same kind of value, and not that key with a word added (gl_version, first_frame_ms are an engine's own)."""
    missing = [k for k in KEYS if k not in tree]
    for key, value in tree.items():
        if key in KEYS:
            continue
        for meant in difflib.get_close_matches(str(key), missing, n=3, cutoff=MISSPELT_RATIO):
            added_word = str(key).startswith(meant + "_") or str(key).endswith("_" + meant)
            if added_word or isinstance(value, bool) or not isinstance(value, KINDS[meant]):
                continue
            raise InputError(f"{where}: {key} is not a timings key; did you mean {meant}? (read: {', '.join(KEYS)})")


def _no_constant(name: str):
    raise ValueError(f"holds {name}, which is no JSON number")


def read(path: Path, origin: str = "") -> EngineTimings:
    """Parse an engine's timings file (module docstring); InputError naming the file and key."""
    where = f"{origin}: {path}" if origin else str(path)
    data = read_input(Path(path), "timings file", MAX_BYTES, InputError)
    try:
        tree = json.loads(data.decode("utf-8"), parse_constant=_no_constant)
    except (UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"{where}: not a readable JSON file of frame timings ({exc})") from None
    if not isinstance(tree, dict):
        raise InputError(f"{where}: must be a JSON object, got {type(tree).__name__}")
    _check_keys(tree, where)
    frames = tree.get("frame_ms", None)
    if frames is None:
        frames = []
    elif not isinstance(frames, list) or not frames:
        raise InputError(f"{where}: frame_ms = {frames!r}: must be a non-empty list of milliseconds (or left out)")
    frame_ms = tuple(_ms(v, f"{where}: frame_ms[{i}]") for i, v in enumerate(frames))
    pre = tree.get("precompute_ms")
    return EngineTimings(engine=_text(tree, "engine", path), version=_text(tree, "version", path), frame_ms=frame_ms,
                         precompute_ms=None if pre is None else _ms(pre, f"{where}: precompute_ms"),
                         notes=_text(tree, "notes", path))
