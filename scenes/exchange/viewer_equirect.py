"""The equirect convention glTF viewers use, and the resampling between it and iblcheck's.

The viewer convention is three.js's `equirectUv` (src/renderers/shaders/ShaderChunk/common.glsl.js):

    u = atan(d.z, d.x) / (2 pi) + 0.5,   v = asin(d.y) / pi + 0.5

with the texture uploaded `flipY = true` (HDRLoader / RGBELoader set it for float textures), so v = 1, the
+Y pole, is the file's first row. In rows counted from the top, t = 1 - v = acos(d.y) / pi. Texels are
centred: texel (r, c) is the point u = (c + 0.5) / W, t = (r + 0.5) / H, and a bilinear lookup reads
`x = u W - 0.5` (wrapping) and `y = t H - 0.5` (clamped to the first and last rows).

iblcheck's convention (scenes/environment/directions.py) is u_i = atan2(d.x, -d.z) / (2 pi) with
align-corner rows (row = v (H - 1)). With d = (sin t cos p, cos t, sin t sin p), p = atan2(d.z, d.x):
atan2(cos p, -sin p) = p + pi/2, so u_i = (p + pi/2) / (2 pi) = u_viewer - 1/4: the viewer's map is
iblcheck's turned by a quarter turn in u, and its rows sit at texel centres instead of on the poles.

- `to_viewer(env, rotation_deg)`: a viewer map of the same W x H whose texel (r, c) holds iblcheck's
  `envmap.lookup(env, d, rotation_deg)` at the direction d of that texel's centre: a viewer's bilinear
  lookup equals iblcheck's at every texel centre (between centres both interpolate their own samples).
- `from_viewer(vmap)`: an iblcheck map whose `envmap.lookup` equals the viewer's bilinear lookup of `vmap`
  everywhere (to float rounding) when W is a multiple of 4: it has the same columns, shifted by W / 4,
  and 2H + 1 rows, the odd ones on the viewer's row centres and the even ones halfway between them
  (both lookups are linear in the polar angle between those rows). Other widths are resampled.
"""

from __future__ import annotations

import numpy as np

from scenes.environment import envmap
from scenes.environment.directions import TWO_PI, equirect_directions, normalize

#: one sentence for the export's sidecar
CONVENTION = ("three.js equirectUv: u = 0.5 + atan2(d.z, d.x) / (2 pi) left to right, row 0 is +Y "
              "(t = acos(d.y) / pi from the top), texel (r, c) centred at ((c + 0.5) / W, (r + 0.5) / H), "
              "bilinear, columns wrapping")


def viewer_uv(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(u, t) of world directions (..., 3) in the viewer convention: u in [0, 1), t = acos(d.y) / pi from the top."""
    d = normalize(d)
    u = 0.5 + np.arctan2(d[..., 2] + 0.0, d[..., 0] + 0.0) / TWO_PI
    u = u - np.floor(u)
    t = np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / np.pi
    return u, t


def viewer_direction(u: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Inverse of `viewer_uv`: unit directions (..., 3)."""
    u, t = np.asarray(u, dtype=np.float64), np.asarray(t, dtype=np.float64)
    p, th = np.broadcast_arrays(TWO_PI * (u - 0.5), np.pi * t)
    s = np.sin(th)
    return np.stack([s * np.cos(p), np.cos(th), s * np.sin(p)], axis=-1)


def texel_directions(height: int, width: int) -> np.ndarray:
    """World directions (H, W, 3) of the viewer map's texel centres."""
    u = (np.arange(width) + 0.5) / width
    t = (np.arange(height) + 0.5) / height
    return viewer_direction(u[None, :], t[:, None])


def to_viewer(env: np.ndarray, rotation_deg: float = 0.0) -> np.ndarray:
    """The viewer-convention map (H, W, 3) float32 of iblcheck's `env`, turned by `rotation_deg` about +Y."""
    h, w = np.asarray(env).shape[:2]
    return envmap.lookup(env, texel_directions(h, w), rotation_deg)


def lookup(vmap: np.ndarray, d: np.ndarray) -> np.ndarray:
    """A viewer's bilinear lookup (..., 3) of a viewer-convention map at world directions d (..., 3)."""
    vmap = np.asarray(vmap)
    h, w = vmap.shape[:2]
    u, t = viewer_uv(d)
    x = u * w - 0.5
    y = np.clip(t * h - 0.5, 0.0, h - 1.0)
    x0 = np.floor(x)
    fx = (x - x0)[..., None]
    x0 = x0.astype(np.int64) % w
    x1 = (x0 + 1) % w
    y0 = np.clip(np.floor(y).astype(np.int64), 0, max(h - 2, 0))
    fy = (y - y0)[..., None]
    y1 = np.minimum(y0 + 1, h - 1)
    top = vmap[y0, x0] * (1.0 - fx) + vmap[y0, x1] * fx
    bottom = vmap[y1, x0] * (1.0 - fx) + vmap[y1, x1] * fx
    return (top * (1.0 - fy) + bottom * fy).astype(np.float32)


def from_viewer(vmap: np.ndarray) -> np.ndarray:
    """iblcheck's map (2H + 1, W, 3) float32 of a viewer-convention map (H, W, 3) (see the module docstring)."""
    vmap = np.asarray(vmap, dtype=np.float32)
    h, w = vmap.shape[:2]
    if w % 4:
        # no column of iblcheck's falls on a viewer column: resample at iblcheck's own sample points
        return lookup(vmap, equirect_directions(2 * h + 1, w))
    # iblcheck column c sits at u_i = (c + 0.5) / W, the viewer's u = u_i + 1/4: viewer column c + W/4
    shifted = np.roll(vmap, -(w // 4), axis=1).astype(np.float64)
    out = np.empty((2 * h + 1, w, 3))
    out[1::2] = shifted  # row 2k + 1: polar angle pi (k + 0.5) / H, the viewer's row centre k
    out[0] = shifted[0]  # the poles: the viewer clamps to its first and last rows
    out[-1] = shifted[-1]
    out[2:-1:2] = 0.5 * (shifted[:-1] + shifted[1:])  # row 2k: halfway between viewer rows k - 1 and k
    return out.astype(np.float32)
