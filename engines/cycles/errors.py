"""The bridge's two failures, each one stderr line and an exit code (the engine-command contract):
a scene Cycles cannot render as asked (2) and bpy missing on this Python (3).

Standard library only: this package runs under Blender's own Python environment, which has bpy and numpy
and nothing of iblcheck's other packages.
"""

from __future__ import annotations

import reprlib

_REPR = reprlib.Repr()
_REPR.maxstring = 80
_REPR.maxother = 80
_REPR.maxlist = _REPR.maxdict = 8


def short_repr(value: object) -> str:
    """repr(value), cut to one readable line."""
    return _REPR.repr(value)


class SceneRejected(ValueError):
    """The export cannot be rendered (a missing or wrong key, a material Cycles has no equivalent of).
    Exit code 2; the message names the file, the key and the value."""

    exit_code = 2


class EngineMissing(RuntimeError):
    """bpy cannot be imported on this Python. Exit code 3."""

    exit_code = 3
