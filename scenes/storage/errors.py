"""Exceptions raised for bad input. The CLI maps them to exit code 2.

Every message names the offending file (or object), the key or position, the bad
value and what would have been allowed, so a user can fix the input without a
traceback.
"""

from __future__ import annotations


class InputError(ValueError):
    """Base class of all bad-input errors (a ValueError, so callers may catch either)."""


class SceneError(InputError):
    """A scene file (or an override) is malformed or holds a value out of range."""


class EnvMapError(InputError):
    """An environment map cannot be read or holds non-finite / negative radiance."""


class MeshError(InputError):
    """A mesh file cannot be read or describes no usable triangles."""


class MissingCapability(RuntimeError):
    """The machine lacks something (OpenGL context, Mitsuba variant). CLI exit code 3.

    `hint` says what to install.
    """

    def __init__(self, message: str, hint: str = "") -> None:
        super().__init__(message)
        self.hint = hint
