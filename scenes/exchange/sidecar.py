"""The export's sidecar, `iblcheck-export.json`: what glTF cannot say (the environment's file, convention,
rotation and intensity; the image's size, pixel centres and output; how each material was exported).

rotation_y_deg = THETA turns the map about +Y by THETA degrees, right-handed (counter-clockwise seen from
+Y), as Mitsuba's rotate([0, 1, 0], THETA): radiance arriving from world direction d is the map's at
R_y(-THETA) d (scenes/environment/directions.py, `to_environment_frame`).
"""

from __future__ import annotations

import json
from pathlib import Path

from scenes.storage.errors import InputError
from scenes.storage.files import read_input

NAME = "iblcheck-export.json"
FORMAT = "iblcheck-export"
VERSION = 1
ROTATION = ("rotate the map about +Y by rotation_y_deg degrees, right-handed (counter-clockwise seen from +Y), as "
            "Mitsuba's rotate([0, 1, 0], deg): radiance arriving from world direction d is the map's at R_y(-deg) d")
OUTPUT = ("linear radiance RGB float32 (OpenEXR or PFM): no tone mapping, no exposure, no anti-aliasing, "
          "no dithering")
#: the most bytes a sidecar may have
MAX_BYTES = 16 << 20


def read(path: str | Path) -> dict:
    """The sidecar's JSON, checked to be one (InputError naming the file otherwise)."""
    path = Path(path)
    data = read_input(path, "export sidecar", MAX_BYTES, InputError)
    try:
        doc = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not a JSON export sidecar ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise InputError(f"{path}: format = {doc.get('format') if isinstance(doc, dict) else None!r}: "
                         f"not an iblcheck export sidecar (expected {FORMAT!r})")
    if doc.get("version") != VERSION:
        raise InputError(f"{path}: version = {doc.get('version')!r}: this iblcheck reads version {VERSION}")
    return doc


def is_export(folder: Path) -> bool:
    """Whether `folder` holds an earlier export (its sidecar reads as one)."""
    try:
        read(folder / NAME)
    except InputError:
        return False
    return True
