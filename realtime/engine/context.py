"""The headless OpenGL 4.3 context (EGL): Mesa llvmpipe on CPU machines, the driver on a GPU.

One context per process, created on first use. `GLCONTEXT_DEVICE_INDEX` picks the EGL device.
"""

from __future__ import annotations

import os
from functools import lru_cache

from scenes.storage.errors import MissingCapability

HINT = ("install an EGL driver with OpenGL 4.3: on Debian `apt-get install libegl1 libgl1-mesa-dri` "
        "(Mesa llvmpipe is enough)")


@lru_cache(maxsize=1)
def get_context():
    """The shared moderngl context; MissingCapability (CLI exit 3) when there is none."""
    try:
        import moderngl  # deferred: a missing moderngl is a MissingCapability (exit 3), not an ImportError
    except ImportError as exc:
        raise MissingCapability(f"moderngl is not installed ({exc})", "run `make setup`") from None
    kwargs = {"backend": "egl", "require": 430}
    if "GLCONTEXT_DEVICE_INDEX" in os.environ:
        kwargs["device_index"] = int(os.environ["GLCONTEXT_DEVICE_INDEX"])
    try:
        return moderngl.create_standalone_context(**kwargs)
    except Exception as exc:  # glcontext raises plain Exceptions for missing EGL / old GL
        raise MissingCapability(f"no OpenGL 4.3 context through EGL ({exc})", HINT) from None


def renderer_name() -> str:
    ctx = get_context()
    return f"{ctx.info['GL_RENDERER']} / {ctx.info['GL_VERSION']}"


def is_software() -> bool:
    """True on Mesa's software rasterisers, where GL timer queries are not meaningful."""
    name = get_context().info["GL_RENDERER"].lower()
    return any(s in name for s in ("llvmpipe", "softpipe", "swrast", "lavapipe"))
