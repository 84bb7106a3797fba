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


class PluginError(Exception):
    """A technique plugin (entry-point group `iblcheck.techniques`) cannot be used. Its message is one line
    naming the plugin's distribution and entry point; the subclasses choose the CLI's exit code."""


class PluginDeclarationError(PluginError, InputError):
    """A plugin's declaration is wrong (a missing field, a wrong type, a clashing name, a default out of
    its range). CLI exit code 2."""


class PluginLoadError(PluginError, MissingCapability):
    """A plugin cannot be loaded: its module does not import, or its GLSL does not compile. CLI exit code 3."""
