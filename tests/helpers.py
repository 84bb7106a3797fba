"""Small helpers shared by tests (import as `from tests.helpers import ...`)."""

from __future__ import annotations

from pathlib import Path


def write_scene(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def sphere_scene_text(name: str, environment: str, material: str, size: int, shape: str = "sphere",
                      object_lines: str = "", tables: str = "") -> str:
    """TOML of one object seen from z = 4 with a 32-degree fov; `environment` holds the body of the
    [environment] table, `object_lines` extra keys of the object, `tables` whole extra tables."""
    obj = f'shape = "{shape}"\n' + (object_lines + "\n" if object_lines else "") + f"material = {material}"
    return (f'\nname = "{name}"\n[environment]\n{environment}\n[camera]\norigin = [0.0, 0.0, 4.0]\n'
            f"fov_deg = 32.0\nwidth = {size}\nheight = {size}\n[[objects]]\n{obj}\n{tables}\n")
