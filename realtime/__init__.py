"""Real-time environment lighting in moderngl: the paper's method (Gu et al. 2006, docs/contract.md
section 3) and the techniques it is measured against (docs/architecture.md).

    realtime.render(scene) -> Render

The default techniques are the paper's: cube map with a 2x2 box mip chain, SH9 irradiance
`n^T M n` (`realtime/techniques/sh/diffuse_sh.py`) and the glossy lookup at a LOD
(`realtime/techniques/box/glossy_box.py`).
`realtime/engine/technique.py` is the interface (techniques are found through their declarations,
scenes/model/technique_registry.py), `realtime/engine/frame.py` composes a frame and times it,
`realtime/engine/gpu.py` holds the shared environment filter and assembles the shading pass from the
chosen techniques' GLSL.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["object_distance", "render"]


def __getattr__(name: str) -> Any:
    """`render` and `object_distance`, loaded on first use: the lazy loading of this package, decided here
    once. The scene model reads every technique's declaration (realtime/techniques/*/declaration.py),
    and importing those must not load OpenGL, which `realtime.engine.frame` does."""
    if name in __all__:
        return getattr(import_module("realtime.engine.frame"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
