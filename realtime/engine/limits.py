"""The GL context's limits, checked before a resource is made (never silently exceeded).

An OpenGL implementation refuses a texture wider than GL_MAX_TEXTURE_SIZE, a storage block larger
than GL_MAX_SHADER_STORAGE_BLOCK_SIZE or a dispatch of more work groups than
GL_MAX_COMPUTE_WORK_GROUP_COUNT with a GL error that moderngl does not always raise: the resource is
left incomplete and reads as black, and the render exits 0 with a wrong image. Every place that
creates a GL object whose size follows from the scene calls one of the checks below first; a texture
side or a work-group count beyond the limit raises `GLLimitExceeded` (a MissingCapability: CLI exit 3)
with one line naming the limit, its value on this context and the scene key that asked for the size.
A storage buffer beyond GL_MAX_SHADER_STORAGE_BLOCK_SIZE gets a `warning:` line instead
(`check_storage` says why).

The one case where going on is honest is an environment map too wide or tall for one texture:
`fit_equirect` downsamples it (area-weighted, so the map's integral is kept) with a `warning:` line
saying that the real-time image reads the downsampled map while the reference reads the full one.

The limits are read from `ctx.info` (moderngl's table of glGet values), so a test can substitute a
context whose `info` holds small limits.
"""

from __future__ import annotations

import warnings

import numpy as np

from scenes.environment.directions import equirect_solid_angles
from scenes.storage.errors import MissingCapability

#: the limit that bounds each kind of texture: its sides (the array's layers are bounded apart)
TEXTURE_LIMITS = {
    "2d": "GL_MAX_TEXTURE_SIZE",
    "array": "GL_MAX_TEXTURE_SIZE",
    "cube": "GL_MAX_CUBE_MAP_TEXTURE_SIZE",
    "3d": "GL_MAX_3D_TEXTURE_SIZE",
    "framebuffer": "GL_MAX_RENDERBUFFER_SIZE",
}
LAYERS_LIMIT = "GL_MAX_ARRAY_TEXTURE_LAYERS"
STORAGE_LIMIT = "GL_MAX_SHADER_STORAGE_BLOCK_SIZE"
GROUPS_LIMIT = "GL_MAX_COMPUTE_WORK_GROUP_COUNT"
#: what OpenGL 4.3 guarantees at least (section 23, table 23.53 ff.), used when a driver does not report a value
GUARANTEED = {
    "GL_MAX_TEXTURE_SIZE": 1024,
    "GL_MAX_CUBE_MAP_TEXTURE_SIZE": 1024,
    "GL_MAX_3D_TEXTURE_SIZE": 256,
    "GL_MAX_RENDERBUFFER_SIZE": 1024,
    "GL_MAX_ARRAY_TEXTURE_LAYERS": 256,
    "GL_MAX_SHADER_STORAGE_BLOCK_SIZE": 1 << 24,
    "GL_MAX_COMPUTE_WORK_GROUP_COUNT": (65535, 65535, 65535),
}
HINT = "use smaller values for the key named, or run on a GPU whose OpenGL driver allows more"


class GLLimitExceeded(MissingCapability):
    """A resource the scene asks for exceeds a limit of this GL context. CLI exit code 3."""


def limit(ctx, name: str):
    """The context's value of a GL limit (`ctx.info[name]`), or OpenGL 4.3's guaranteed minimum."""
    value = ctx.info.get(name)
    return GUARANTEED[name] if value is None else value


def _refuse(what: str, amount: str, name: str, value, key: str) -> None:
    raise GLLimitExceeded(f"{key}: {what} needs {amount}, above this OpenGL context's {name} = {value}", HINT)


def check_texture(ctx, kind: str, size: tuple[int, ...], key: str, what: str = "a texture") -> None:
    """Refuse a texture of `kind` ("2d", "array", "cube", "3d", "framebuffer") whose sides `size`
    (width, height[, depth or layers]) exceed the context's limit; `key` is the scene key that set them."""
    name = TEXTURE_LIMITS[kind]
    value = int(limit(ctx, name))
    sides = size[:2] if kind == "array" else size
    if max(sides) > value:
        _refuse(what, f"{' x '.join(str(int(s)) for s in size)} texels", name, value, key)
    if kind == "array" and len(size) > 2:
        layers = int(limit(ctx, LAYERS_LIMIT))
        if size[2] > layers:
            _refuse(what, f"{int(size[2])} layers", LAYERS_LIMIT, layers, key)


class StorageLimitWarning(UserWarning):
    """A storage buffer is larger than the block size the driver reports (it may still accept it)."""


def check_storage(ctx, nbytes: int, key: str, what: str = "a storage buffer") -> None:
    """Say so in one `warning:` line when a shader storage buffer of `nbytes` is larger than
    GL_MAX_SHADER_STORAGE_BLOCK_SIZE.

    A warning, not a refusal: the limit is the least size the driver promises for one block, and
    drivers accept more (Mesa llvmpipe reports 128 MiB and reads and writes a 200 MiB block correctly;
    `realtime.vct.resolution = 128` needs 224 MiB per cascade). Refusing would stop renders that are
    right; staying silent would hide that the result rests on more than the driver promises."""
    value = int(limit(ctx, STORAGE_LIMIT))
    if nbytes > value:
        warnings.warn(f"{key}: {what} needs {int(nbytes)} bytes, above this OpenGL context's {STORAGE_LIMIT} = "
                      f"{value}: the driver accepted it, but a driver that keeps to its limit drops what lies "
                      "beyond it", StorageLimitWarning, stacklevel=2)


def check_groups(ctx, counts: tuple[int, ...], key: str, what: str = "a compute dispatch") -> None:
    """Refuse a dispatch of `counts` (x[, y[, z]]) work groups beyond GL_MAX_COMPUTE_WORK_GROUP_COUNT."""
    value = tuple(int(v) for v in limit(ctx, GROUPS_LIMIT))
    for axis, (n, most) in enumerate(zip(counts, value, strict=False)):
        if n > most:
            _refuse(what, f"{int(n)} work groups along {'xyz'[axis]}", GROUPS_LIMIT, value, key)


# -- an environment map too large for one texture --------------------------------------------


def _integrate_bins(values: np.ndarray, n_out: int, axis: int) -> np.ndarray:
    """Integrals of the piecewise-constant `values` (one texel = one unit) over `n_out` equal bins
    spanning the whole `axis`: the running sum is piecewise linear, so it is read exactly at the bins'
    edges by linear interpolation between texel boundaries."""
    values = np.moveaxis(values, axis, 0)
    n_in = values.shape[0]
    running = np.concatenate([np.zeros_like(values[:1]), np.cumsum(values, axis=0)])
    edges = np.arange(n_out + 1) * (n_in / n_out)
    whole = np.minimum(np.floor(edges).astype(np.int64), n_in - 1)
    frac = (edges - whole)[(...,) + (None,) * (values.ndim - 1)]
    at_edges = running[whole] + frac * values[whole]
    return np.moveaxis(np.diff(at_edges, axis=0), 0, axis)


def downsample_equirect(env: np.ndarray, width: int, height: int) -> np.ndarray:
    """An (H, W, 3) equirect map resampled to (height, width) by area: each new texel is the solid-angle
    weighted mean of the old texels it covers (columns of a row have equal solid angle; rows are
    weighted by theirs), so the map's integral over the sphere is kept."""
    h, w = env.shape[:2]
    env = env.astype(np.float64)
    if width < w:
        env = _integrate_bins(env, width, axis=1) * (width / w)
    if height < h:
        omega = equirect_solid_angles(h, 1)[:, 0]  # row weights (only their ratios matter)
        power = _integrate_bins(env * omega[:, None, None], height, axis=0)
        weight = _integrate_bins(omega, height, axis=0)
        env = power / weight[:, None, None]
    return env.astype(np.float32)


def fit_equirect(ctx, env: np.ndarray, key: str) -> np.ndarray:
    """The map as one 2D texture can hold it: itself when both sides fit GL_MAX_TEXTURE_SIZE, else
    downsampled to fit (`downsample_equirect`) with one `warning:` line naming `key` (the map)."""
    h, w = env.shape[:2]
    most = int(limit(ctx, "GL_MAX_TEXTURE_SIZE"))
    if w <= most and h <= most:
        return env
    width, height = min(w, most), min(h, most)
    warnings.warn(f"{key}: the map is {w} x {h} texels, beyond this OpenGL context's GL_MAX_TEXTURE_SIZE = "
                  f"{most}: the real-time image reads it downsampled to {width} x {height} (area-weighted, its "
                  "integral kept) while the reference reads the full map", stacklevel=2)
    return downsample_equirect(env, width, height)
