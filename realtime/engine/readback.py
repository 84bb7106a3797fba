"""Read one mip level of a cube map back to numpy (tests, previews, references).

moderngl's `TextureCube.read` has no mip-level argument, so the level is bound as an image and
copied into a buffer by `dump_level.comp`.
"""

from __future__ import annotations

import moderngl
import numpy as np

from realtime.engine.gpu import groups, shader_source


def read_cube_level(ctx: moderngl.Context, cube: moderngl.TextureCube, level: int) -> np.ndarray:
    """Faces (6, s, s, 3) float32 of mip level `level` (s = cube face size >> level), row 0 at t = 0."""
    size = max(1, cube.size[0] >> level)
    prog = ctx.compute_shader(shader_source("dump_level.comp"))
    out = ctx.buffer(reserve=6 * size * size * 16)
    try:
        cube.bind_to_image(0, read=True, write=False, level=level)
        out.bind_to_storage_buffer(3)
        prog["size"] = size
        prog.run(groups(size), groups(size), 6)
        ctx.memory_barrier()
        return np.frombuffer(out.read(), dtype="f4").reshape(6, size, size, 4)[..., :3].copy()
    finally:
        out.release()
        prog.release()
