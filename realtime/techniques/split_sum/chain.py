"""The split sum's GGX-prefiltered chain on the GPU: one cube per level (mappings.Level: a roughness and a
face size), each texel the source environment convolved with the n = v = r GGX lobe of its level's
roughness (prefilter_ggx.comp, sample sets from samples.py), rebuilt every frame from the environment cube
and its box chain (filtered importance sampling reads the coarser levels).

A level is a cube of its own, not a mip of one texture: three.js' chain keeps its roughest levels at 16
texels, and per_material's levels all have the base size, which one mip chain cannot hold. The shader
reads an object's two levels itself (glossy_split_sum.glsl), which is what textureLod does between two
mips.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import moderngl
import numpy as np

from realtime.engine import limits
from realtime.engine.gpu import groups, shader_source
from realtime.engine.readback import read_cube_level
from realtime.techniques.split_sum.mappings import Level
from realtime.techniques.split_sum.samples import prefilter_samples

#: texture unit the source cube is bound to while the levels are written (with a sampler object of its own
#: for trilinear filtering, unbound afterwards)
SOURCE_UNIT = 7


class GGXChain:
    """`textures[k]`: level k's cube (rgba32f, one mip level, bilinear), prefiltered by `run(cube)`.

    `samples[k]` half vectors are drawn for level k with `sampling` ("importance" or "vndf"); the source
    is a cube of face `source_size` with its full mip chain, read at 0.5 log2(Omega_s / Omega_p) + `bias`."""

    def __init__(self, ctx: moderngl.Context, levels: Sequence[Level], source_size: int, samples: Sequence[int],
                 sampling: str = "importance", bias: float = 0.0) -> None:
        if not levels or len(samples) != len(levels):
            raise ValueError(f"{len(levels)} levels and {len(samples)} sample counts: one count per level")
        if source_size < 1 or source_size & (source_size - 1):
            raise ValueError(f"source_size must be a power of two, got {source_size}")
        self.ctx = ctx
        self.levels = tuple(levels)
        self.source_size = source_size
        self.bias = float(bias)
        for level in self.levels:
            limits.check_texture(ctx, "cube", (level.size, level.size), "realtime.split_sum.size",
                                 "a level of the prefiltered chain")
        rows = [prefilter_samples(level.roughness, n, source_size, sampling) for level, n in zip(levels, samples,
                                                                                                 strict=True)]
        self.counts = [len(r) for r in rows]
        self.firsts = [int(x) for x in np.cumsum([0, *self.counts[:-1]])]
        data = np.concatenate(rows).astype("f4").tobytes()
        limits.check_storage(ctx, len(data), "realtime.split_sum.samples", "the prefilter's sample sets")
        self.sample_buffer = ctx.buffer(data)
        self.prog = ctx.compute_shader(shader_source("prefilter_ggx.comp", package=__package__))
        self.sampler = ctx.sampler(filter=(moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR))
        self.textures = []
        for level in self.levels:
            tex = ctx.texture_cube((level.size, level.size), 4, dtype="f4")
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.textures.append(tex)

    def run(self, cube: moderngl.TextureCube) -> None:
        """Write every level from the environment cube `cube` (its mip chain built)."""
        if cube.size[0] != self.source_size:
            raise ValueError(f"source cube has face size {cube.size[0]}, the chain was sampled for {self.source_size}")
        prog = self.prog
        self.sampler.texture = cube
        self.sampler.use(SOURCE_UNIT)
        self.sample_buffer.bind_to_storage_buffer(6)
        prog["source"] = SOURCE_UNIT
        prog["bias"] = self.bias
        prog["max_lod"] = float(math.log2(self.source_size))
        try:
            for level, tex, first, count in zip(self.levels, self.textures, self.firsts, self.counts, strict=True):
                tex.bind_to_image(1, read=False, write=True, level=0)
                prog["size"] = level.size
                prog["first"] = first
                prog["count"] = count
                prog.run(groups(level.size), groups(level.size), 6)
            self.ctx.memory_barrier()
        finally:
            self.sampler.clear(SOURCE_UNIT)  # leave the unit's filtering to its texture again
            self.sampler.texture = None

    def read_level(self, k: int) -> np.ndarray:
        """Faces (6, s, s, 3) float32 of level k."""
        return read_cube_level(self.ctx, self.textures[k], 0)

    def release(self) -> None:
        for obj in (self.prog, self.sampler, self.sample_buffer, *self.textures):
            obj.release()
