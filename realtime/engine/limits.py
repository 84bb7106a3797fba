"""The GL context's limits, checked before a resource is made (never silently exceeded).

An OpenGL implementation refuses a texture wider than GL_MAX_TEXTURE_SIZE, a storage block larger
than GL_MAX_SHADER_STORAGE_BLOCK_SIZE or a dispatch of more work groups than
GL_MAX_COMPUTE_WORK_GROUP_COUNT with a GL error that moderngl does not always raise: the resource is
left incomplete and reads as black, and the render exits 0 with a wrong image. Every place that
creates a GL object whose size follows from the scene calls one of the checks below first; a texture
side or a work-group count beyond the limit raises `GLLimitExceeded` (a MissingCapability: CLI exit 3)
with one line naming the limit, its value on this context and the scene key that asked for the size.
A storage buffer beyond GL_MAX_SHADER_STORAGE_BLOCK_SIZE gets a `warning:` line instead
(`check_storage` says why), up to 2^31 - 1 bytes, past which it is refused.

Beyond the limits that can be queried, a driver may still refuse a resource (memory): `check_created`
reads the GL error flag after a resource is made and refuses the same way.
The shading pass's active samplers are known only to the linker: techniques that together sample more
textures than GL_MAX_TEXTURE_IMAGE_UNITS (16 guaranteed; voxel cone tracing alone samples 13 3D textures, 16
samplers with its deferred glossy read's gloss texture, the environment store and its broad-lobe table)
fail to link, and `sampler_refusal` turns that link error into the same refusal, naming the techniques.

The one case where going on is honest is an environment map too wide or tall for one texture:
`fit_equirect` downsamples it (area-weighted, so the map's integral is kept) with a `warning:` line
saying that the real-time image reads the downsampled map while the reference reads the full one.

The limits are read from `ctx.info` (moderngl's table of glGet values), so a test can substitute a
context whose `info` holds small limits.
"""

from __future__ import annotations

import warnings

import numpy as np

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
    "GL_MAX_TEXTURE_IMAGE_UNITS": 16,
}
SAMPLERS_LIMIT = "GL_MAX_TEXTURE_IMAGE_UNITS"
#: no storage buffer past this many bytes, whatever GL_MAX_SHADER_STORAGE_BLOCK_SIZE says: Mesa llvmpipe (which
#: reports 128 MiB and accepts more) crashed the process reading past byte 2^31 of a buffer (of a 2.28 GB one,
#: an atomic add at its end worked, a read there crashed)
MAX_STORAGE_BYTES = (1 << 31) - 1
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
    GL_MAX_SHADER_STORAGE_BLOCK_SIZE; refuse one past MAX_STORAGE_BYTES whatever the driver reports.

    Up to MAX_STORAGE_BYTES a warning, not a refusal: the limit is the least size the driver promises for
    one block, and drivers accept more (Mesa llvmpipe reports 128 MiB and reads and writes a 200 MiB block correctly;
    `realtime.vct.resolution = 128` needs 136 MiB a buffer). Refusing would stop renders that are
    right; staying silent would hide that the result rests on more than the driver promises."""
    if nbytes > MAX_STORAGE_BYTES:
        raise GLLimitExceeded(f"{key}: {what} needs {int(nbytes)} bytes, above {MAX_STORAGE_BYTES} (2^31 - 1), the "
                              "largest storage buffer iblcheck binds on any driver", HINT)
    value = int(limit(ctx, STORAGE_LIMIT))
    if nbytes > value:
        warnings.warn(f"{key}: {what} needs {int(nbytes)} bytes, above this OpenGL context's {STORAGE_LIMIT} = "
                      f"{value}: a driver may accept it (Mesa llvmpipe does); one that keeps to its limit drops "
                      "what lies beyond it", StorageLimitWarning, stacklevel=2)


def check_groups(ctx, counts: tuple[int, ...], key: str, what: str = "a compute dispatch") -> None:
    """Refuse a dispatch of `counts` (x[, y[, z]]) work groups beyond GL_MAX_COMPUTE_WORK_GROUP_COUNT."""
    value = tuple(int(v) for v in limit(ctx, GROUPS_LIMIT))
    for axis, (n, most) in enumerate(zip(counts, value, strict=False)):
        if n > most:
            _refuse(what, f"{int(n)} work groups along {'xyz'[axis]}", GROUPS_LIMIT, value, key)


def sampler_refusal(ctx, link_log: str, key: str) -> GLLimitExceeded | None:
    """The refusal for a program that did not link because its stage samples more textures than
    GL_MAX_TEXTURE_IMAGE_UNITS (which samplers are active is known only to the linker, so this reads its log:
    Mesa says "Too many fragment shader texture samplers", other drivers name samplers too); None for any
    other link error, which is a bug and raised as it is."""
    text = link_log.lower()
    if "sampler" not in text or not any(w in text for w in ("too many", "exceed", "limit", "maximum")):
        return None
    return GLLimitExceeded(f"{key}: the shading pass samples more textures than this OpenGL context's "
                           f"{SAMPLERS_LIMIT} = {limit(ctx, SAMPLERS_LIMIT)} allows", HINT)


#: the GL errors that mean a resource was not made: too large for memory, or a size beyond a limit
REFUSALS = ("GL_OUT_OF_MEMORY", "GL_INVALID_VALUE")


def _errors(ctx) -> list[str]:
    """Every GL error flag set, cleared (glGetError returns and clears one flag per call)."""
    out = []
    for _ in range(16):  # an implementation keeps at most one flag per error kind
        error = ctx.error
        if error == "GL_NO_ERROR":
            break
        out.append(error)
    return out


def clear_errors(ctx) -> None:
    """Forget GL errors raised before (by earlier work, or by Python collecting a released object)."""
    _errors(ctx)


def check_created(ctx, key: str, what: str) -> None:
    """Refuse what was just made when the driver flagged that it could not make it.

    The backstop of the checks above: a driver may refuse a resource within every reported limit (Mesa
    llvmpipe makes no texture above 1 GiB, so a 4096-texel RGBA32F cube map is GL_OUT_OF_MEMORY), and the
    resource then reads as black. `ctx.error` is glGetError; call `clear_errors` before making it. Only
    the errors of REFUSALS count: another flag may come from work the resource has no part in (moderngl
    objects released when Python collects them)."""
    refused = [e for e in _errors(ctx) if e in REFUSALS]
    if refused:
        raise GLLimitExceeded(f"{key}: the OpenGL driver did not make {what} ({refused[0]}): it is beyond what "
                              "this machine's driver allows", HINT)


# -- an environment map too large for one texture --------------------------------------------


def _bin_integrals(values: np.ndarray, old: np.ndarray, new: np.ndarray, measure) -> np.ndarray:
    """Integrals over the bins between the edges `new` of the piecewise-constant `values` (value k on
    [old[k], old[k + 1]), along axis 0) against the measure whose cumulative function is `measure`.
    The running integral is exact at the old edges and, inside an old bin, grows with the measure, so a
    new bin that cuts an old one takes exactly its share of it."""
    shape = (-1,) + (1,) * (values.ndim - 1)
    cut = measure(old)
    running = np.concatenate([np.zeros_like(values[:1]), np.cumsum(values * np.diff(cut).reshape(shape), axis=0)])
    k = np.clip(np.searchsorted(old, new, side="right") - 1, 0, len(values) - 1)
    at_edges = running[k] + (measure(new) - cut[k]).reshape(shape) * values[k]
    return np.diff(at_edges, axis=0)


def _row_edges(height: int) -> np.ndarray:
    """Polar angles bounding the rows of an equirect map: row r is the sample at pi r / (H - 1) and stands
    for the band half a row either side, clipped at the poles (scenes/environment/directions.py)."""
    return np.clip((np.arange(height + 1) - 0.5) * (np.pi / (height - 1)), 0.0, np.pi)


def downsample_equirect(env: np.ndarray, width: int, height: int) -> np.ndarray:
    """An (H, W, 3) equirect map resampled to (height, width) by area: each new texel is the solid-angle
    weighted mean of the old texels it covers, so the map's integral over the sphere (with the weights of
    `scenes.environment.directions.equirect_solid_angles`) is kept exactly.

    Columns are cells of equal solid angle; a row is the band of polar angles around its sample, whose
    solid angle grows with cos(top) - cos(bottom) (`_row_edges`)."""
    h, w = env.shape[:2]
    env = env.astype(np.float64)
    if width < w:
        cols = _bin_integrals(np.moveaxis(env, 1, 0), np.arange(w + 1) / w, np.arange(width + 1) / width,
                              lambda u: u)
        env = np.moveaxis(cols, 0, 1) * width
    if height < h:
        new = _row_edges(height)
        env = _bin_integrals(env, _row_edges(h), new, lambda t: -np.cos(t)) / np.diff(-np.cos(new))[:, None, None]
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
