"""A scene named on a command line or in a manifest: a scene file (TOML), `builtin:NAME`, or a glTF Render
Fidelity scenario (`.json`, scenes/exchange/fidelity.py)."""

from __future__ import annotations

from pathlib import Path

from scenes.exchange.fidelity import read_scenario
from scenes.model.scene import Scene
from scenes.model.scene import load as load_scene_file


def load(spec: str) -> Scene:
    """The scene `spec` names (module docstring)."""
    return read_scenario(spec) if Path(spec).suffix.lower() == ".json" else load_scene_file(spec)
