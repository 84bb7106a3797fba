"""The sphere map (Blinn & Newell 1976; OpenGL's GL_SPHERE_MAP): one square map, made for a capture view.

Frame: the capture camera's eye space, as gluLookAt builds it: x right, y up, z towards the viewer
(the camera looks along -z). `capture_frame(forward, up)` gives the world -> map rotation (rows:
right, up, back). A unit direction d (in that frame) goes to

    (x, y) = (d.x, d.y) / p,   p = sqrt(d.x^2 + d.y^2 + (d.z + 1)^2)

i.e. OpenGL's s = x / 2 + 1/2, t = y / 2 + 1/2 (the mirror ball seen from the capture view). With
rho = |(x, y)| = sin(theta / 2), theta the angle from +z: the centre is the direction back at the
viewer, the whole rim is the single direction -z straight behind the ball (the singularity), and

    d = (2 sqrt(1 - rho^2) x, 2 sqrt(1 - rho^2) y, 1 - 2 rho^2)

It is Lambert's azimuthal equal-area projection scaled to the unit disc: dOmega/dA = 4 everywhere (all
texels fully inside the disc cover the same solid angle, a ratio of 1), but not conformal: the
radial stretch 2 / sqrt(1 - rho^2) and the tangential one 2 sqrt(1 - rho^2) part without bound
towards the rim (their ratio is 1 / (1 - rho^2)), which is where the map's "speckles" come from.

Beyond the disc (texels at rho > 1, which the box chain and bilinear lookups at the rim read), a texel
holds the direction on the same great circle past -z: rho' = 2 - rho on the opposite azimuth, so the
fill is continuous across the rim. Those texels weigh zero in projections (the disc covers 4 pi).

Exact texel solid angles: 4 x the area of texel ∩ disc (scenes/environment/discmap.py with g = 2).
Arrays of maps have shape (1, size, size, C).
"""

from __future__ import annotations

import math

import numpy as np

from scenes.environment import discmap
from scenes.environment.directions import normalize

NAME = "sphere_map"
LAYERS = 1
#: one map of (s sqrt 6)^2 texels holds as many as a cube of face s (6 s^2)
BUDGET_FACTOR = 6.0


def map_size(face_size: int) -> int:
    """Side of the map at the texel budget of a cube with faces `face_size`: s sqrt(6) rounded to the
    nearest power of two (2 s for a power-of-two s: (2 s)^2 = 4 s^2 texels, against the cube's 6 s^2)."""
    return 2 ** round(math.log2(face_size * math.sqrt(BUDGET_FACTOR)))


def texel_count(size: int) -> int:
    return LAYERS * size * size


def capture_frame(forward, up) -> np.ndarray:
    """World -> map rotation (3, 3) of a capture camera looking along `forward` with `up` (gluLookAt's
    eye space: rows right, true up, -forward). An `up` parallel to `forward` is replaced by the world
    axis least aligned with it."""
    f = normalize(np.asarray(forward, dtype=np.float64))
    u = np.asarray(up, dtype=np.float64)
    if np.linalg.norm(np.cross(f, u)) < 1e-6 * max(np.linalg.norm(u), 1e-300):
        u = np.eye(3)[int(np.argmin(np.abs(f)))]
    right = normalize(np.cross(f, u))
    true_up = np.cross(right, f)
    return np.stack([right, true_up, -f])


def position_to_direction(x: np.ndarray, y: np.ndarray, layer: np.ndarray | int = 0) -> np.ndarray:
    """Unit directions (..., 3) in the map's frame of plane positions; beyond the disc, the great-circle
    continuation past -z (module docstring)."""
    x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    rho = np.hypot(x, y)
    outside = rho > 1.0
    # past the rim: rho' = 2 - rho (at least 0) on the opposite azimuth
    scale = np.where(outside, -np.maximum(2.0 - rho, 0.0) / np.where(rho > 0, rho, 1.0), 1.0)
    x, y = x * scale, y * scale
    r2 = np.minimum(x * x + y * y, 1.0)
    k = 2.0 * np.sqrt(1.0 - r2)
    return np.stack([k * x, k * y, 1.0 - 2.0 * r2], axis=-1)


def direction_to_position(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(layer (always 0), x, y) of directions (..., 3) in the map's frame. The singular direction -z
    maps to the rim point (1, 0)."""
    d = normalize(d)
    p = np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2 + (d[..., 2] + 1.0) ** 2)
    ok = p > 0.0
    safe = np.where(ok, p, 1.0)
    x = np.where(ok, d[..., 0] / safe, 1.0)
    y = np.where(ok, d[..., 1] / safe, 0.0)
    return np.zeros(x.shape, dtype=np.int64), x, y


def density(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """dOmega / dA inside the disc: 4 (equal area)."""
    return np.full(np.broadcast(np.asarray(x), np.asarray(y)).shape, 4.0)


def texel_directions(size: int) -> np.ndarray:
    """Unit directions (1, size, size, 3) of every texel centre, in the map's frame."""
    x, y = discmap.texel_positions(size)
    return position_to_direction(x, y)[None]


def _line_integral(a, b, c, t0, t1):
    return 2.0 * (t1 - t0)  # g = 2


def texel_solid_angles(size: int) -> np.ndarray:
    """Exact solid angle (1, size, size) of each texel's part inside the disc: 4 x its area there.
    They sum to 4 pi (the disc covers every direction)."""
    return discmap.clipped_integrals(size, _line_integral, g_rim=2.0)[None]


def direction_to_texel(d: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(layer, row, column) of the texel that holds each direction (in the map's frame)."""
    layer, x, y = direction_to_position(d)
    row, col = discmap.position_to_texel(x, y, size)
    return layer, row, col
