"""The per-frame GPU half of wavelet PRT (compute shaders in this package): the lighting's Haar transform, the
selection of its K largest area-weighted coefficients, and each vertex's sum.

    wavelet_haar.comp    per level h = 1 .. s/2: the level's coefficients from the engine's 2x2 box chain
                         (one texel of coefficients per 2x2 texels of the box level of face side 2h), their keys
    wavelet_select.comp  one workgroup: the exact K-th largest key by a bitwise binary search over the keys'
                         float bits with a shared atomic counter, ties to the smaller index; the kept
                         coefficients compacted in index order, and a dense buffer (zeros except the K kept)
    wavelet_dot.comp     per vertex, for each kept index a binary search in the vertex's sorted index list
                         (Ng et al.'s cost model: K searches of log2(nnz) reads), or where that costs more than
                         its nnz entries, a scan of them against the dense selected lighting: the same terms in
                         the same order, min(K log2(nnz), nnz) reads per vertex

The cube level read has face side cube_size (the engine's box chain of the level-0 cube; a cube_size above the
level-0 face is refused by the scene, and here by ValueError).
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from realtime.engine import limits
from realtime.engine.gpu import groups, shader_source
from realtime.techniques.wavelet_prt.wavelet_transfer import SparseTransfer

SELECT_LOCAL = 256  # wavelet_select.comp's workgroup
DOT_LOCAL = 64  # wavelet_dot.comp's workgroup


class WaveletLighting:
    """The lighting's Haar coefficients and the K kept of them, for one cube_size and K."""

    def __init__(self, ctx: moderngl.Context, cube_size: int, terms: int) -> None:
        n = 6 * cube_size * cube_size
        if cube_size < 2 or cube_size & (cube_size - 1):
            raise ValueError(f"wavelet PRT cube_size must be a power of two >= 2, got {cube_size}")
        if not 1 <= terms <= n:
            raise ValueError(f"wavelet PRT terms must be 1..{n} (6 x cube_size^2), got {terms}")
        self.ctx, self.size, self.terms, self.n = ctx, cube_size, terms, n
        self.haar_prog = ctx.compute_shader(shader_source("wavelet_haar.comp", package=__package__))
        self.select_prog = ctx.compute_shader(shader_source("wavelet_select.comp", package=__package__))
        limits.check_storage(ctx, n * 16, "realtime.wavelet_prt.cube_size", "the lighting's Haar coefficients")
        self.coefficients = ctx.buffer(reserve=n * 16)
        self.dense = ctx.buffer(reserve=n * 16)
        self.kept_index = ctx.buffer(reserve=terms * 4)
        self.kept_value = ctx.buffer(reserve=terms * 16)

    def run(self, cube: moderngl.TextureCube) -> None:
        """Transform and select the level of `cube` (whose level 0 is cube.size[0]) with faces cube_size."""
        base = cube.size[0]
        if self.size > base:
            raise ValueError(f"wavelet PRT cube_size {self.size} is above the cube map's level-0 face {base}")
        self.coefficients.bind_to_storage_buffer(1)
        self.haar_prog["size"] = self.size
        h = 1
        while h < self.size:
            level = int(math.log2(base // (2 * h)))  # the box level of face side 2h
            cube.bind_to_image(0, read=True, write=False, level=level)
            self.haar_prog["h"] = h
            self.haar_prog.run(groups(h), groups(h), 6)
            h *= 2
        self.ctx.memory_barrier()
        self.coefficients.bind_to_storage_buffer(1)
        self.dense.bind_to_storage_buffer(2)
        self.kept_index.bind_to_storage_buffer(3)
        self.kept_value.bind_to_storage_buffer(4)
        self.select_prog["n"] = self.n
        self.select_prog["k"] = self.terms
        self.select_prog["index_bits"] = max(1, (self.n - 1).bit_length())
        self.select_prog.run(1, 1, 1)
        self.ctx.memory_barrier()

    def read_coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """(coefficients (N, 3), keys (N,)) as last computed, float64."""
        c = np.frombuffer(self.coefficients.read(), dtype="f4").reshape(self.n, 4).astype(np.float64)
        return c[:, :3], c[:, 3]

    def read_kept(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(kept indices (K,), their values (K, 3), the dense selected lighting (N, 3)) as last computed."""
        idx = np.frombuffer(self.kept_index.read(), dtype="u4").astype(np.int64)
        val = np.frombuffer(self.kept_value.read(), dtype="f4").reshape(self.terms, 4)[:, :3].astype(np.float64)
        dense = np.frombuffer(self.dense.read(), dtype="f4").reshape(self.n, 4)[:, :3].astype(np.float64)
        return idx, val, dense

    def release(self) -> None:
        for obj in (self.haar_prog, self.select_prog, self.coefficients, self.dense, self.kept_index,
                    self.kept_value):
            obj.release()


class WaveletObject:
    """One object's sparse transfer on the GPU and its per-vertex irradiance (vec4 per vertex)."""

    def __init__(self, ctx: moderngl.Context, transfer: SparseTransfer, what: str) -> None:
        self.ctx = ctx
        self.vertices = len(transfer.offsets) - 1
        if transfer.offsets[-1] >= 1 << 32:
            raise ValueError(f"{what}: {transfer.offsets[-1]} stored coefficients do not fit 32-bit offsets")
        offsets = np.ascontiguousarray(transfer.offsets, dtype="u4")
        indices = np.ascontiguousarray(transfer.indices, dtype="u4")
        values = np.ascontiguousarray(transfer.values, dtype="f4")
        for name, a in (("indices", indices), ("values", values)):
            limits.check_storage(ctx, a.nbytes, "realtime.wavelet_prt.threshold", f"{what}'s transfer {name}")
        self.prog = ctx.compute_shader(shader_source("wavelet_dot.comp", (f"CHANNELS {transfer.channels}",),
                                                     package=__package__))
        # a buffer of no bytes cannot be made: an object without entries gets one unused word
        self.offsets = ctx.buffer(offsets.tobytes())
        self.indices = ctx.buffer(indices.tobytes() if len(indices) else bytes(4))
        self.values = ctx.buffer(values.tobytes() if len(indices) else bytes(4))
        self.irradiance = ctx.buffer(reserve=max(self.vertices, 1) * 16)

    def run(self, lighting: WaveletLighting) -> None:
        lighting.dense.bind_to_storage_buffer(2)
        lighting.kept_index.bind_to_storage_buffer(3)
        lighting.kept_value.bind_to_storage_buffer(4)
        self.offsets.bind_to_storage_buffer(5)
        self.indices.bind_to_storage_buffer(6)
        self.values.bind_to_storage_buffer(7)
        self.irradiance.bind_to_storage_buffer(8)
        self.prog["vertices"] = self.vertices
        self.prog["k"] = lighting.terms
        self.prog.run(groups(self.vertices, DOT_LOCAL), 1, 1)

    def read(self) -> np.ndarray:
        """(V, 3) float64 irradiance as last computed."""
        return np.frombuffer(self.irradiance.read(), dtype="f4").reshape(-1, 4)[:self.vertices, :3].astype(
            np.float64)

    def release(self) -> None:
        for obj in (self.prog, self.offsets, self.indices, self.values, self.irradiance):
            obj.release()
