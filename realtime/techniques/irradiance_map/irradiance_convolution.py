"""Irradiance cube map by brute-force convolution: the exact sum that the paper's SH9 approximates.

    E(n) = sum_texels L(w) max(n.w, 0) dOmega(w)        [units of L x sr: W m^-2 for L in W m^-2 sr^-1]

over every texel w of one level of the environment cube map (face size `source_size`), with the
exact texel solid angles (scenes.environment.cubemap.texel_solid_angles, as the SH projection uses), for n =
each texel direction of an output cube map of face size `size`. The shader then reads
E = texture(irr, n).rgb and shades kd / pi E, like the paper's E(n) = n^T M n (docs/contract.md section 3).

By default the sum is normalised by its discrete kernel mass,

    E(n) = pi sum(L c dOmega) / sum(c dOmega),   c = max(n.w, 0),

which makes a constant map of radiance 1 give E = pi exactly (the plain sum is off by up to 1e-3
at source face 16 and 8e-5 at 32: the midpoint rule on the cosine's kink at the horizon), as
groundtruth/exact/quadrature.py normalises its kernels. On a real probe both agree with the exact
integral to ~7e-4 of the largest E at source face 32 (2.5e-3 at 16, 6e-3 at 8): the level's own
resolution, not the kernel, limits them there. `normalize=False` gives the plain sum.

`IrradianceConvolver` is the GPU kernel (irradiance_pack.comp, irradiance_convolve.comp: several
outputs per invocation, each output's antipode from the same n.w); `irradiance_cube_numpy` is the
float64 reference of the same sum.
"""

from __future__ import annotations

import moderngl
import numpy as np

from realtime.engine import limits
from realtime.engine.gpu import groups, shader_source
from realtime.engine.readback import read_cube_level
from scenes.environment import cubemap

#: output texels per invocation along a row (one load of a source texel feeds this many outputs)
MAX_BLOCK = 8
#: local size of the packing pass (irradiance_pack.comp)
PACK_GROUP = 64


def texel_weights(source_size: int) -> np.ndarray:
    """(6, s, s, 4) float64: w dOmega (xyz) and dOmega (w) of every texel of a face-size-s cube level."""
    d = cubemap.texel_directions(source_size)
    omega = np.broadcast_to(cubemap.texel_solid_angles(source_size)[None, :, :, None], d.shape[:3] + (1,))
    return np.concatenate([d * omega, omega], axis=-1)


def irradiance_cube_numpy(faces_level: np.ndarray, out_size: int, normalize: bool = True,
                          chunk: int = 2048) -> np.ndarray:
    """Reference (float64) of IrradianceConvolver: E (6, o, o, 3) at the output texel directions.

    `faces_level` (6, s, s, 3) is the source level's radiance; see the module docstring for the sum.
    """
    src = np.asarray(faces_level, dtype=np.float64)
    s = src.shape[1]
    wt = texel_weights(s).reshape(-1, 4)
    L = src.reshape(-1, 3)
    n = cubemap.texel_directions(out_size).reshape(-1, 3)
    out = np.empty((len(n), 3))
    for a in range(0, len(n), chunk):
        c = np.maximum(n[a:a + chunk] @ wt[:, :3].T, 0.0)  # max(n.w, 0) dOmega
        e = c @ L
        out[a:a + chunk] = np.pi * e / c.sum(axis=1, keepdims=True) if normalize else e
    return out.reshape(6, out_size, out_size, 3)


def _layout(size: int) -> tuple[int, int, int]:
    """(B, LX, LY): B outputs per invocation along x, local size LX x LY, for an output face of `size`.

    Rows of B * LX texels span the face where they can; LY keeps >= 2 workgroups per face pair
    at small sizes (2 cores) and <= 32 invocations per workgroup (llvmpipe: 8-wide SIMD)."""
    b = min(MAX_BLOCK, size)
    lx = max(1, min(8, size // b))
    ly = max(1, min(32 // lx, size // 2 if size >= 16 else size))
    return b, lx, ly


class IrradianceConvolver:
    """E(n) of one source cube level into `self.texture` (TextureCube size x size, rgba32f, LINEAR).

    `run(cube, source_level)` reads level `source_level` of `cube`, whose face size must be
    `source_size`, in two compute passes (irradiance_pack.comp, irradiance_convolve.comp);
    `read()` returns the faces (6, size, size, 3)."""

    def __init__(self, ctx: moderngl.Context, size: int, source_size: int, normalize: bool = True) -> None:
        self.ctx = ctx
        self.size = size
        self.source_size = source_size
        self.normalize = normalize
        self.block, self.local_x, self.local_y = _layout(size)
        self.pack_prog = ctx.compute_shader(shader_source("irradiance_pack.comp", package=__package__))
        defines = (f"B {self.block}", f"LX {self.local_x}", f"LY {self.local_y}")
        defines += ("NORMALIZE",) if normalize else ()
        self.prog = ctx.compute_shader(shader_source("irradiance_convolve.comp", defines, package=__package__))
        key = "realtime.irradiance_map.source_size"
        limits.check_texture(ctx, "2d", (source_size, 6 * source_size), key, "the convolution weights")
        limits.check_storage(ctx, 6 * source_size * source_size * 2 * 16, key, "the packed source texels")
        limits.check_groups(ctx, (groups(6 * source_size * source_size, PACK_GROUP),), key, "the packing dispatch")
        limits.check_texture(ctx, "cube", (size, size), "realtime.irradiance_map.size", "the irradiance cube map")
        w = texel_weights(source_size).reshape(6 * source_size, source_size, 4)
        self.weights = ctx.texture((source_size, 6 * source_size), 4, w.astype("f4").tobytes(), dtype="f4")
        self.weights.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.n_texels = 6 * source_size * source_size
        self.packed = ctx.buffer(reserve=self.n_texels * 2 * 16)
        self.texture = ctx.texture_cube((size, size), 4, dtype="f4")
        self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)

    def run(self, cube: moderngl.TextureCube, source_level: int) -> None:
        """Convolve level `source_level` of `cube` (face size `source_size`) into `self.texture`."""
        if max(1, cube.size[0] >> source_level) != self.source_size:
            raise ValueError(f"level {source_level} of a {cube.size[0]} cube is not face size {self.source_size}")
        cube.bind_to_image(0, read=True, write=False, level=source_level)
        self.weights.use(2)
        self.packed.bind_to_storage_buffer(4)
        self.pack_prog["weights"] = 2
        self.pack_prog["source_size"] = self.source_size
        self.pack_prog.run(groups(self.n_texels, PACK_GROUP), 1, 1)
        self.ctx.memory_barrier()
        self.texture.bind_to_image(1, read=False, write=True, level=0)
        self.prog["size"] = self.size
        self.prog["n_texels"] = self.n_texels
        self.prog.run(groups(self.size, self.block * self.local_x), groups(self.size, self.local_y), 3)
        self.ctx.memory_barrier()

    def read(self) -> np.ndarray:
        """Irradiance faces (6, size, size, 3) float32."""
        return read_cube_level(self.ctx, self.texture, 0)

    def release(self) -> None:
        for obj in (self.pack_prog, self.prog, self.weights, self.packed, self.texture):
            obj.release()
