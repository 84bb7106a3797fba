"""The display pass on the GPU: Reinhard tone mapping then sRGB, in GLSL (display.frag).

It mirrors `scenes.model.tonemap.tonemap`; tests check the two agree to 1e-4. `DisplayPass` keeps its
GL objects so that the pass can be timed per frame (paper suite E4, "+ tone mapping").
"""

from __future__ import annotations

import moderngl
import numpy as np

from realtime.engine import limits
from realtime.engine.context import get_context
from realtime.engine.gpu import shader_source
from realtime.engine.timing import summarize, timed


class DisplayPass:
    """An HDR (H, W) RGBA32F texture -> tone-mapped sRGB, drawn as one full-screen triangle."""

    def __init__(self, ctx, rgb: np.ndarray):
        self.ctx = ctx
        h, w = rgb.shape[:2]
        self.size = (w, h)
        limits.check_texture(ctx, "framebuffer", (w, h), "camera.width x camera.height", "the display image")
        self.src = ctx.texture((w, h), 4, np.dstack([rgb, np.ones((h, w))]).astype("f4").tobytes(), dtype="f4")
        self.src.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.dst = ctx.texture((w, h), 4, dtype="f4")
        self.fbo = ctx.framebuffer(color_attachments=[self.dst])
        self.prog = ctx.program(vertex_shader=shader_source("fullscreen.vert"),
                                fragment_shader=shader_source("display.frag"))
        self.vao = ctx.vertex_array(self.prog, [])

    def draw(self, key: float, white: float, exposure: float, adapt_lum: float) -> None:
        self.fbo.use()
        self.ctx.viewport = (0, 0, *self.size)
        self.ctx.disable(moderngl.DEPTH_TEST)
        self.src.use(0)
        self.prog["hdr"] = 0
        self.prog["scale"] = key / max(adapt_lum, 1e-30) * 2.0**exposure
        self.prog["white"] = white
        self.vao.render(moderngl.TRIANGLES, vertices=3)

    def read(self) -> np.ndarray:
        w, h = self.size
        out = np.frombuffer(self.fbo.read(components=4, dtype="f4"), dtype="f4").reshape(h, w, 4)[..., :3]
        return out.copy()  # texture rows are the array rows (no window flip: data in, data out)

    def release(self) -> None:
        for r in (self.vao, self.prog, self.fbo, self.dst, self.src):
            r.release()


def tonemap_gpu(rgb: np.ndarray, key: float, white: float, exposure: float, adapt_lum: float) -> np.ndarray:
    """sRGB-encoded (H, W, 3) float32 of linear radiance (H, W, 3), computed by display.frag."""
    p = DisplayPass(get_context(), rgb)
    try:
        p.draw(key, white, exposure, adapt_lum)
        return p.read()
    finally:
        p.release()


def display_ms(rgb: np.ndarray, key: float, white: float, exposure: float, adapt_lum: float,
               frames: int = 30, warmup: int = 5) -> dict[str, float]:
    """Median and p90 milliseconds of the display pass on an image of rgb's size (docs/contract.md section 7)."""
    ctx = get_context()
    p = DisplayPass(ctx, rgb)
    try:
        samples = [timed(ctx, lambda: p.draw(key, white, exposure, adapt_lum)) for _ in range(warmup + frames)]
        return summarize({"display": samples[warmup:]})
    finally:
        p.release()
