"""The display pass on the GPU: Reinhard tone mapping then sRGB, in GLSL (display.frag).

It mirrors `scenes.tonemap.tonemap`; tests check the two agree to 1e-4.
"""

from __future__ import annotations

import moderngl
import numpy as np

from .context import get_context
from .gpu import shader_source


def tonemap_gpu(rgb: np.ndarray, key: float, white: float, exposure: float, adapt_lum: float) -> np.ndarray:
    """sRGB-encoded (H, W, 3) float32 of linear radiance (H, W, 3), computed by display.frag."""
    ctx = get_context()
    h, w = rgb.shape[:2]
    src = ctx.texture((w, h), 4, np.dstack([rgb, np.ones((h, w))]).astype("f4").tobytes(), dtype="f4")
    src.filter = (moderngl.NEAREST, moderngl.NEAREST)
    dst = ctx.texture((w, h), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[dst])
    prog = ctx.program(vertex_shader=shader_source("fullscreen.vert"), fragment_shader=shader_source("display.frag"))
    vao = ctx.vertex_array(prog, [])
    try:
        fbo.use()
        ctx.viewport = (0, 0, w, h)
        ctx.disable(moderngl.DEPTH_TEST)
        src.use(0)
        prog["hdr"] = 0
        prog["scale"] = key / max(adapt_lum, 1e-30) * 2.0**exposure
        prog["white"] = white
        vao.render(moderngl.TRIANGLES, vertices=3)
        out = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype="f4").reshape(h, w, 4)[..., :3]
        return out.copy()  # texture rows are the array rows (no window flip: data in, data out)
    finally:
        for r in (vao, prog, fbo, dst, src):
            r.release()
