"""The dual paraboloid parameterization (Heidrich & Seidel 1998): two square maps, one per hemisphere.

Frame: fixed in the world (view independent). Map 0 (the front, layer 0) holds the hemisphere
z >= 0, map 1 (the back) z < 0. A unit direction d goes to the plane position

    (x, y) = (d.x, d.y) / (1 + |d.z|)                    (inside the unit disc)

the point where the paraboloid f(x, y) = 1/2 - (x^2 + y^2) / 2 reflects d towards the map's axis:
this is the stereographic projection of the hemisphere, and its inverse (per map, z negated on the back)

    d = (2 x, 2 y, 1 - r^2) / (1 + r^2),   r^2 = x^2 + y^2

is defined on the whole plane: beyond the disc (r > 1) it continues into the other hemisphere, so
texels outside the disc hold the radiance just across the seam (the box chain and bilinear lookups
near the seam read real neighbours, not black). Texels outside the disc weigh zero in projections.

Solid angle per plane area: dOmega/dA = 4 / (1 + r^2)^2, from 4 at the centre to 1 at the rim (a
ratio of 4, no stretch: the map is conformal). Exact texel solid angles come from Green's theorem
(scenes/environment/discmap.py) with g(r) = 2 / (1 + r^2).

Texel grids and texture coordinates: scenes/environment/discmap.py (row 0 at y = -1 = t 0, as the cube map's).
Arrays of maps have shape (2, size, size, C).
"""

from __future__ import annotations

import math

import numpy as np

from scenes.environment import discmap
from scenes.environment.directions import normalize

NAME = "dual_paraboloid"
LAYERS = 2
#: texels of one cube face stand for this many texels of one map side squared: a cube of face s holds
#: 6 s^2 texels, two maps of (s sqrt 3)^2 hold the same
BUDGET_FACTOR = 3.0


def map_size(face_size: int) -> int:
    """Side of each map at the texel budget of a cube with faces `face_size`: s sqrt(3) rounded to
    the nearest power of two (2 s for a power-of-two s: two maps of (2 s)^2 = 8 s^2 texels, against
    the cube's 6 s^2)."""
    return 2 ** round(math.log2(face_size * math.sqrt(BUDGET_FACTOR)))


def texel_count(size: int) -> int:
    return LAYERS * size * size


def position_to_direction(x: np.ndarray, y: np.ndarray, layer: np.ndarray | int = 0) -> np.ndarray:
    """Unit directions (..., 3) of plane positions on map `layer` (0: z >= 0, 1: z < 0), the whole plane."""
    x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    r2 = x * x + y * y
    z = (1.0 - r2) / (1.0 + r2)
    z = np.where(np.asarray(layer) == 1, -z, z)
    return np.stack([2.0 * x / (1.0 + r2), 2.0 * y / (1.0 + r2), z], axis=-1)


def direction_to_position(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(layer, x, y) of directions (..., 3): layer 0 for z >= 0, the plane position in the unit disc."""
    d = normalize(d)
    layer = np.where(d[..., 2] >= 0.0, 0, 1)
    den = 1.0 + np.abs(d[..., 2])
    return layer, d[..., 0] / den, d[..., 1] / den


def density(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """dOmega / dA at plane positions: 4 / (1 + r^2)^2."""
    r2 = np.asarray(x, dtype=np.float64) ** 2 + np.asarray(y, dtype=np.float64) ** 2
    return 4.0 / (1.0 + r2) ** 2


def texel_directions(size: int) -> np.ndarray:
    """Unit directions (2, size, size, 3) of every texel centre (outside the disc: across the seam)."""
    x, y = discmap.texel_positions(size)
    return np.stack([position_to_direction(x, y, layer) for layer in range(LAYERS)])


def _line_integral(a, b, c, t0, t1):
    # g(r) = 2 / (1 + r^2) along r(t)^2 = a t^2 + b t + c: 2 * (2 / sqrt(D)) [atan((2 a t + b) / sqrt(D))]
    # with D = 4 a (c + 1) - b^2 > 0 (1 + r^2 never vanishes)
    root = np.sqrt(4.0 * a * (c + 1.0) - b * b)
    return 4.0 / root * (np.arctan((2.0 * a * t1 + b) / root) - np.arctan((2.0 * a * t0 + b) / root))


def texel_solid_angles(size: int) -> np.ndarray:
    """Exact solid angle (2, size, size) of each texel's part inside the disc; both maps alike.
    They sum to 4 pi."""
    one = discmap.clipped_integrals(size, _line_integral, g_rim=1.0)
    return np.stack([one] * LAYERS)


def direction_to_texel(d: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(layer, row, column) of the texel that holds each direction."""
    layer, x, y = direction_to_position(d)
    row, col = discmap.position_to_texel(x, y, size)
    return layer, row, col
