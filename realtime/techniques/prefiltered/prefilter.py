"""The environment convolved with the normalised Phong lobe: a prefiltered cube-map chain.

    G(r) = int L(l) (N + 1) / (2 pi) max(r.l, 0)^N dl          [radiance: the lobe integrates to 1]

for r = each texel direction of levels first_level .. log2(base) of a cube map of the source's
size. It is the paper's glossy lobe about the mirror direction (docs/contract.md section 3); unlike GGX
no n = v approximation is needed; the horizon cut is ignored, as in the paper's box chain. The
shader reads it like the box chain, textureLod(prefiltered, r, lod).

Estimator (prefilter_phong.comp): importance sampling of the lobe itself with a Hammersley set,
cos a = xi1^(1 / (N + 1)), phi = 2 pi xi2 (pdf = the lobe, so f / pdf = 1 and G is the sample mean),
and filtered importance sampling (Krivanek & Colbert, "Real-time shading with filtered importance
sampling", 2008; as Filament's cmgen and Khronos' glTF-IBL-Sampler do for GGX): a sample of density
pdf stands for Omega_s = 1 / (samples pdf) sr and reads the source's mip level
lod = 0.5 log2(Omega_s / Omega_p) + bias, Omega_p = 4 pi / (6 base^2), clamped to [0, log2 base].
N = 0 is the uniform hemisphere about r. For N up to 1e6, 1 - cos a is kept without cancellation
(-expm1(log(xi1) / (N + 1))) and the direction is built in a robust frame about r (Duff et al. 2017).

`phong_convolve_numpy` is the exact texel sum of the same lobe over one cube level (the reference).
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from realtime.engine import limits
from realtime.engine.gpu import groups, shader_source
from realtime.engine.low_discrepancy import radical_inverse_base2
from realtime.engine.readback import read_cube_level
from scenes.environment import cubemap

#: texture unit the source cube is bound to while the levels are written (a sampler object of its
#: own sets trilinear filtering there, and is unbound afterwards)
SOURCE_UNIT = 7


def phong_samples(exponent: float, samples: int, base_size: int) -> np.ndarray:
    """(samples, 4) float64: lobe-frame direction (sin a cos phi, sin a sin phi, 1 - cos a) and the
    FIS level 0.5 log2(Omega_s / Omega_p) before bias and clamping (see the module docstring).

    Hammersley points (xi1, xi2) = ((i + 0.5) / n, radical inverse of i), warped to the lobe:
    cos^(N+1) a = xi1. Then pdf = (N + 1) / (2 pi) cos^N a with log cos^N a = N / (N + 1) log xi1.
    """
    i = np.arange(samples)
    xi1 = (i + 0.5) / samples
    xi2 = radical_inverse_base2(i)
    log_xi1 = np.log(xi1)
    one_minus_cos = -np.expm1(log_xi1 / (exponent + 1.0))
    sin_a = np.sqrt(one_minus_cos * (2.0 - one_minus_cos))
    phi = 2.0 * np.pi * xi2
    log2_pdf = math.log2((exponent + 1.0) / (2.0 * np.pi)) + exponent / (exponent + 1.0) * log_xi1 / math.log(2.0)
    omega_p = 4.0 * np.pi / (6.0 * base_size * base_size)
    half_log2_ratio = 0.5 * (-math.log2(samples) - log2_pdf - math.log2(omega_p))
    return np.stack([sin_a * np.cos(phi), sin_a * np.sin(phi), one_minus_cos, half_log2_ratio], axis=-1)


def phong_texel_weights(size: int, directions: np.ndarray, exponent: float) -> np.ndarray:
    """Normalised weights (k, 6, size, size) of the lobe about each direction over a cube level's texels:
    lobe(r.w) dOmega(w) / sum(lobe dOmega), in float64.

    cos^N is taken in log space and shifted by its maximum before exp, so a lobe narrower than a
    texel still gives finite weights (then all on the nearest texels) instead of 0 / 0.
    N = 0: uniform over the hemisphere r.w >= 0."""
    r = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    r = r / np.linalg.norm(r, axis=1, keepdims=True)
    w = cubemap.texel_directions(size).reshape(-1, 3)
    log_omega = np.tile(np.log(cubemap.texel_solid_angles(size)).reshape(-1), 6)
    d = 1.0 - r @ w.T  # (k, 6 s^2); float64 keeps 1e-16 of it: 1e-7 relative at N = 1e9
    above = d <= 1.0
    with np.errstate(divide="ignore"):
        log_pow = exponent * np.log1p(-np.minimum(d, 1.0)) if exponent > 0 else np.zeros_like(d)
    logw = np.where(above, log_pow + log_omega[None, :], -np.inf)
    wts = np.exp(logw - logw.max(axis=1, keepdims=True))
    wts /= wts.sum(axis=1, keepdims=True)
    return wts.reshape(-1, 6, size, size)


def phong_convolve_numpy(faces: np.ndarray, directions: np.ndarray, exponent: float, chunk: int = 64) -> np.ndarray:
    """Reference (k, 3): sum_texels L(w) lobe(r.w) dOmega(w) / sum_texels lobe(r.w) dOmega(w) over the
    texels of `faces` (6, s, s, 3), for each of `directions` (k, 3). A constant map gives the constant."""
    faces = np.asarray(faces, dtype=np.float64)
    r = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    L = faces.reshape(-1, 3)
    out = np.empty((len(r), 3))
    for a in range(0, len(r), chunk):
        wts = phong_texel_weights(faces.shape[1], r[a:a + chunk], exponent)
        out[a:a + chunk] = wts.reshape(len(wts), -1) @ L
    return out


class PhongPrefilter:
    """Levels first_level .. log2(base_size) of `self.texture` (TextureCube base_size, rgba32f, full mip
    chain, LINEAR_MIPMAP_LINEAR), each texel the source convolved with the Phong lobe of `exponent`.

    `run(cube, first_level)`: `cube` is the environment cube (same base size) with its mip chain
    built (FIS reads the coarser levels). Levels below first_level are left as they are: readers use
    lod >= first_level. `set_lobe(exponent, samples)` changes the lobe; `bias` is read at each run."""

    def __init__(self, ctx: moderngl.Context, base_size: int, exponent: float, samples: int,
                 bias: float = 0.0) -> None:
        if base_size < 1 or base_size & (base_size - 1):
            raise ValueError(f"base_size must be a power of two, got {base_size}")
        self.ctx = ctx
        self.base_size = base_size
        self.n_levels = int(math.log2(base_size)) + 1
        self.bias = float(bias)
        limits.check_texture(ctx, "cube", (base_size, base_size), "realtime.base_size", "the prefiltered cube map")
        self.prog = ctx.compute_shader(shader_source("prefilter_phong.comp", package=__package__))
        self.texture = ctx.texture_cube((base_size, base_size), 4, dtype="f4")
        self.texture.build_mipmaps()  # allocates every level
        self.texture.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        self.sampler = ctx.sampler(filter=(moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR))
        self.sample_buffer: moderngl.Buffer | None = None
        self.set_lobe(exponent, samples)

    def set_lobe(self, exponent: float, samples: int) -> None:
        """Phong exponent N >= 0 and the number of samples per texel (>= 1); rebuilds the sample set."""
        if exponent < 0 or not math.isfinite(exponent):
            raise ValueError(f"exponent must be finite and >= 0, got {exponent}")
        if samples < 1:
            raise ValueError(f"samples must be >= 1, got {samples}")
        self.exponent = float(exponent)
        self.samples = int(samples)
        data = phong_samples(self.exponent, self.samples, self.base_size).astype("f4").tobytes()
        limits.check_storage(self.ctx, len(data), "realtime.prefiltered.samples", "the prefilter's sample set")
        if self.sample_buffer is not None:
            self.sample_buffer.release()
        self.sample_buffer = self.ctx.buffer(data)

    def run(self, cube: moderngl.TextureCube, first_level: int) -> None:
        """Write levels first_level .. log2(base_size) from the environment cube `cube`."""
        if cube.size[0] != self.base_size:
            raise ValueError(f"source cube has face size {cube.size[0]}, the prefilter {self.base_size}")
        if not 0 <= first_level < self.n_levels:
            raise ValueError(f"first_level must be in [0, {self.n_levels - 1}], got {first_level}")
        prog = self.prog
        self.sampler.texture = cube
        self.sampler.use(SOURCE_UNIT)
        self.sample_buffer.bind_to_storage_buffer(6)
        prog["source"] = SOURCE_UNIT
        prog["samples"] = self.samples
        prog["bias"] = self.bias
        prog["max_lod"] = float(self.n_levels - 1)
        try:
            for level in range(first_level, self.n_levels):
                size = self.base_size >> level
                self.texture.bind_to_image(1, read=False, write=True, level=level)
                prog["size"] = size
                prog.run(groups(size), groups(size), 6)
            self.ctx.memory_barrier()
        finally:
            self.sampler.clear(SOURCE_UNIT)  # leave the unit's filtering to its texture again
            self.sampler.texture = None

    def read_level(self, level: int) -> np.ndarray:
        """Faces (6, s, s, 3) float32 of one level (s = base_size >> level)."""
        return read_cube_level(self.ctx, self.texture, level)

    def release(self) -> None:
        for obj in (self.prog, self.texture, self.sampler, self.sample_buffer):
            obj.release()
