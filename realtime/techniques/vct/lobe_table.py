"""The environment convolved with broad normalised Phong lobes, for voxel cone tracing's glossy reads.

A glossy read asks for L_g(r, N) = (N + 1) / (2 pi) int L(w) max(r . w, 0)^N dw: the injection at the surface's own
exponent, the deferred read at the exponent broadened by the reading cone's aperture and the surfaces' normals
(vct_trace.glsl), which on the diffuse cones is a few units. A mip chain read at the level whose texel covers the
lobe's solid angle (McGuire et al. 2013) hands back a texel's box mean instead: for N up to 2 it is clamped to a
whole cube face, and its footprint is a square, not the lobe's bell. Against the lobe's integral over the texels
of a level weighted by solid angle (3000 directions, five probes, the chain weighted by solid angle), the chain's
read misses by 13-90 % RMS of the mean radiance at N = 0-50 (`benchmarks/vct_lobe_table.py`).

So the integral itself is tabulated: layer j holds N_j = 2^j - 1 (0, 1, 3, ..., 127) over an equirect grid of lobe
axes (vct_lobe_axis.glsl), each texel the quadrature of the lobe over a level of the chain weighted by solid
angle (vct_lobe_table.comp: each texel's mean radiance times its exact solid angle at its centre's direction,
normalised by the same sum over the lobe, so that a constant environment is exact). A read is bilinear in the
axis and a cubic in log2(N + 1) through the four layers around it; above the top layer it blends into the chain
over one octave and reads the chain alone from N = 255 (vct_glossy_env.glsl).

Resolution, against a lobe's angular spread of about sigma = 1 / sqrt(N + 1) rad (5.1 deg at the top layer):
- the source's texels, 2 / s rad wide at a face's centre, no wider than sigma / 2 (s >= 4 sqrt(N + 1), at least
  16 and at most 32 texels a face: `source_size`; at N = 127, where 45 would be asked, 0.7 sigma). Their
  centres stand for them, an error of order (w / sigma)^2 / 24 of the lobe's curvature;
- the grid's texels, 2.8 deg (128 x 64): bilinear interpolation adds w / sqrt(6) = 1.2 deg in quadrature, 2.5 %
  of the top layer's spread.
Measured against the lobe's integral over the base level (`benchmarks/vct_lobe_table.py`): at most 3 % RMS of
the mean radiance for N = 0-50 and 5 % at 127 on the probes, the chain 13-90 %.

Cost: one pass per layer over the grid, each texel summing its source level (214 M terms a build); 0.9 s on
llvmpipe (CPU), after each fill of the environment, only for a scene with a glossy surface (1 MiB, RGBA32F).
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from realtime.engine import limits
from realtime.engine.gpu import EnvironmentFilter, groups, shader_source
from realtime.engine.technique import set_uniform
from scenes.environment import cubemap

#: the table's layers: exponents 2^j - 1, j = 0 .. LAYERS - 1
LAYERS = 8
#: the top layer's exponent: below it a read is the table's alone, from it to 2 TOP_EXPONENT + 1 it blends into
#: the chain (vct_glossy_env.glsl)
TOP_EXPONENT = 2 ** (LAYERS - 1) - 1
#: the grid of lobe axes (equirect, vct_lobe_axis.glsl)
WIDTH, HEIGHT = 128, 64
#: the finest and coarsest faces of the weighted chain's levels the quadrature sums (or the base, if smaller)
SOURCE_MIN, SOURCE_MAX = 16, 32


def layer_exponents() -> np.ndarray:
    """The Phong exponent of each layer, 2^j - 1."""
    return 2.0 ** np.arange(LAYERS) - 1.0


def defines() -> tuple[str, ...]:
    """What a shader that reads the table (vct_glossy_env.glsl) is compiled with: the layer count lives here only."""
    return ("VCT_LOBE_TABLE", f"VCT_LOBE_LAYERS {LAYERS}.0")


def source_size(exponent: float, base_size: int) -> int:
    """The faces' size of the level a layer sums: texels no wider than half the lobe's spread,
    2 / s <= 1 / (2 sqrt(N + 1)) rad at a face's centre (s >= 4 sqrt(N + 1), a power of two in
    [SOURCE_MIN, SOURCE_MAX]), at most the base."""
    s = 2 ** math.ceil(math.log2(4.0 * math.sqrt(exponent + 1.0)))
    return min(max(s, SOURCE_MIN), SOURCE_MAX, base_size)


class LobeTable:
    """The broad-lobe table of one cube environment store, rebuilt after each of its fills (`build`)."""

    def __init__(self, ctx: moderngl.Context, env_filter: EnvironmentFilter) -> None:
        self.ctx = ctx
        self.env_filter = env_filter
        base = env_filter.base_size
        self.sizes = [source_size(n, base) for n in layer_exponents()]
        self.texels: dict[int, moderngl.Buffer] = {}
        for n in sorted(set(self.sizes)):
            texels = np.zeros((6, n, n, 4), "f4")
            texels[..., :3] = cubemap.texel_directions(n)
            texels[..., 3] = cubemap.texel_solid_angles(n)
            self.texels[n] = ctx.buffer(texels.tobytes())
        limits.clear_errors(ctx)
        self.texture = ctx.texture3d((WIDTH, HEIGHT, LAYERS), 4, dtype="f4")
        limits.check_created(ctx, "realtime.base_size", "voxel cone tracing's broad-lobe table")
        self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.texture.repeat_x = True  # the axes' azimuth wraps
        self.texture.repeat_y = self.texture.repeat_z = False
        self.prog = ctx.compute_shader(shader_source("vct_lobe_table.comp", package=__package__))
        self.filled = -1

    def build(self) -> None:
        """Tabulate the store's current fill (nothing if done for it already)."""
        if self.filled == self.env_filter.filled:
            return
        chain = self.env_filter.solid_angle_chain()
        self.texture.bind_to_image(1, read=False, write=True)
        self.prog["table_size"] = (WIDTH, HEIGHT)
        base = self.env_filter.base_size
        for layer, (size, exponent) in enumerate(zip(self.sizes, layer_exponents(), strict=True)):
            chain.bind_to_image(0, read=True, write=False, level=int(math.log2(base // size)))
            self.texels[size].bind_to_storage_buffer(0)
            set_uniform(self.prog, "src_size", size)
            set_uniform(self.prog, "layer", layer)
            set_uniform(self.prog, "exponent", float(exponent))
            self.prog.run(groups(WIDTH), groups(HEIGHT), 1)
        self.ctx.memory_barrier()
        self.filled = self.env_filter.filled

    def bind(self, prog: moderngl.Program | moderngl.ComputeShader, unit: int) -> None:
        """The table on texture `unit`, as vct_glossy_env.glsl's sampler `vct_lobe_table`."""
        self.texture.use(unit)
        set_uniform(prog, "vct_lobe_table", unit)

    def release(self) -> None:
        for obj in (*self.texels.values(), self.texture, self.prog):
            obj.release()
