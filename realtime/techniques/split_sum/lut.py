"""The split sum's DFG table on the GPU (dfg_lut.comp; dfg.py is its numpy mirror), computed once per scene
and stored at the recipe's precision: rg32f, rg16f, or rg8 (unorm), rounded to nearest in the shader."""

from __future__ import annotations

import moderngl
import numpy as np

from realtime.engine import limits
from realtime.engine.gpu import groups, shader_source
from realtime.techniques.split_sum.dfg import PRECISIONS
from scenes.model.materials import PBR_MIN_ALPHA

#: precision -> (image format in the shader, moderngl dtype, numpy dtype of a read-back)
FORMATS = {"f32": ("rg32f", "f4", np.float32), "f16": ("rg16f", "f2", np.float16), "u8": ("rg8", "f1", np.uint8)}
#: the shader's rounding to each format (dfg_lut.comp quantise)
ROUNDING = {"f32": (), "f16": ("LUT_F16",), "u8": ("LUT_U8",)}


class DFGTable:
    """`texture`: (size x size, 2 channels) with x = n.v and y = roughness at texel centres, bilinear and
    clamped at the edges (the lookup every engine does). `compute()` fills it."""

    def __init__(self, ctx: moderngl.Context, size: int, samples: int, precision: str = "f32",
                 visibility: str = "height_correlated") -> None:
        if precision not in PRECISIONS:
            raise ValueError(f"precision must be one of {', '.join(PRECISIONS)}, got {precision!r}")
        if samples < 1:
            raise ValueError(f"samples must be >= 1, got {samples}")
        limits.check_texture(ctx, "2d", (size, size), "realtime.split_sum.lut_size", "the DFG table")
        limits.check_groups(ctx, (groups(size), groups(size)), "realtime.split_sum.lut_size", "the DFG table's pass")
        self.ctx = ctx
        self.size = size
        self.samples = samples
        self.precision = precision
        image_format, dtype, _ = FORMATS[precision]
        defines = (f"LUT_FORMAT {image_format}", *ROUNDING[precision],
                   *(("VISIBILITY_SEPARABLE",) if visibility == "separable" else ()))
        self.prog = ctx.compute_shader(shader_source("dfg_lut.comp", defines, package=__package__))
        self.texture = ctx.texture((size, size), 2, dtype=dtype)
        self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.texture.repeat_x = False  # CLAMP_TO_EDGE: n.v and roughness of 0 and 1 read the edge texels
        self.texture.repeat_y = False

    def compute(self) -> None:
        self.texture.bind_to_image(0, read=False, write=True)
        self.prog["size"] = self.size
        self.prog["samples"] = self.samples
        self.prog["min_alpha"] = PBR_MIN_ALPHA
        self.prog.run(groups(self.size), groups(self.size), 1)
        self.ctx.memory_barrier()

    def read(self) -> np.ndarray:
        """(size, size, 2) float64: [j, i] = (A, B) at n.v = (i + 0.5) / size, roughness = (j + 0.5) / size."""
        _, _, np_dtype = FORMATS[self.precision]
        raw = np.frombuffer(self.texture.read(alignment=1), dtype=np_dtype).reshape(self.size, self.size, 2)
        out = raw.astype(np.float64)
        return out / 255.0 if self.precision == "u8" else out

    def release(self) -> None:
        self.prog.release()
        self.texture.release()
