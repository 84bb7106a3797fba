"""Cube maps in the OpenGL face convention: texel directions, exact solid angles, conversion.

Faces are ordered +X, -X, +Y, -Y, +Z, -Z (GL_TEXTURE_CUBE_MAP_POSITIVE_X + i). A texel at
(row j, column i) of an s x s face has face coordinates s = (i + 0.5) / size, t = (j + 0.5) / size,
row 0 at t = 0 (the first row uploaded to OpenGL), and with sc = 2s - 1, tc = 2t - 1 its
(unnormalised) direction is, per the OpenGL specification's cube-map table:

    +X (1, -tc, -sc)   -X (-1, -tc, sc)   +Y (sc, 1, tc)
    -Y (sc, -1, -tc)   +Z (sc, -tc, 1)    -Z (-sc, -tc, -1)

Faces are filled by looking up each texel's world direction, so shaders sample with world
vectors, unflipped. Arrays of faces have shape (6, size, size, C).
"""

from __future__ import annotations

import numpy as np

from scenes.environment import envmap
from scenes.environment.directions import normalize

FACE_NAMES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")


def face_direction(face: int, sc: np.ndarray, tc: np.ndarray) -> np.ndarray:
    """Unnormalised direction (..., 3) of face coordinates sc, tc in [-1, 1] on face `face`."""
    one = np.ones_like(sc)
    table = {
        0: (one, -tc, -sc),
        1: (-one, -tc, sc),
        2: (sc, one, tc),
        3: (sc, -one, -tc),
        4: (sc, -tc, one),
        5: (-sc, -tc, -one),
    }
    return np.stack(table[face], axis=-1)


def face_coords(size: int) -> np.ndarray:
    """Texel-centre coordinates in [-1, 1]: 2 (k + 0.5) / size - 1 for k = 0..size-1."""
    return 2.0 * (np.arange(size) + 0.5) / size - 1.0


def texel_directions(size: int) -> np.ndarray:
    """Unit world directions (6, size, size, 3) of every texel centre (row index = t)."""
    c = face_coords(size)
    sc, tc = np.meshgrid(c, c, indexing="xy")  # sc varies along columns, tc along rows
    return np.stack([normalize(face_direction(f, sc, tc)) for f in range(6)])


def texel_solid_angles(size: int) -> np.ndarray:
    """Exact solid angle (size, size) of each texel of a face (all six faces are alike).

    The solid angle of the face rectangle [x0, x1] x [y0, y1] at unit distance is
    A(x1, y1) - A(x0, y1) - A(x1, y0) + A(x0, y0) with A(x, y) = atan2(x y, sqrt(x^2 + y^2 + 1))
    (the area of a spherical rectangle; see e.g. Driscoll, "Cubemap texel solid angle", 2012).
    Summed over the six faces it is 4 pi to float64 precision.
    """
    edges = np.linspace(-1.0, 1.0, size + 1)
    x0, y0 = np.meshgrid(edges[:-1], edges[:-1], indexing="xy")
    x1, y1 = np.meshgrid(edges[1:], edges[1:], indexing="xy")

    def area(x, y):
        return np.arctan2(x * y, np.sqrt(x * x + y * y + 1.0))

    return area(x1, y1) - area(x0, y1) - area(x1, y0) + area(x0, y0)


def direction_to_face(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(face, s, t) of world directions: the inverse of the face table (major-axis rule)."""
    d = np.asarray(d, dtype=np.float64)
    ax = np.abs(d)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    major = np.argmax(ax, axis=-1)
    face = np.select([major == 0, major == 1], [np.where(x >= 0, 0, 1), np.where(y >= 0, 2, 3)], np.where(z >= 0, 4, 5))
    m = np.take_along_axis(ax, major[..., None], axis=-1)[..., 0]
    m = np.where(m > 0, m, 1.0)
    # (sc, tc) solved from the table: direction / major = (sc, tc) placed per face
    sc = np.select([face == 0, face == 1, face == 2, face == 3, face == 4], [-z, z, x, x, x], -x) / m
    tc = np.select([face == 0, face == 1, face == 2, face == 3, face == 4], [-y, -y, z, -z, -y], -y) / m
    return face, (sc + 1.0) / 2.0, (tc + 1.0) / 2.0


def from_equirect(env: np.ndarray, size: int, rotation_deg: float = 0.0) -> np.ndarray:
    """Cube faces (6, size, size, 3) float32, each texel the envmap radiance at its centre direction."""
    return envmap.lookup(env, texel_directions(size), rotation_deg)


def box_downsample(faces: np.ndarray) -> np.ndarray:
    """One 2x2 box-filter mip step per face: (6, s, s, C) -> (6, s/2, s/2, C) (the paper's filter)."""
    f = np.asarray(faces, dtype=np.float64)
    s = f.shape[1]
    if s < 2:
        raise ValueError("cannot downsample a 1x1 face")
    return (0.25 * (f[:, 0::2, 0::2] + f[:, 1::2, 0::2] + f[:, 0::2, 1::2] + f[:, 1::2, 1::2])).astype(np.float32)


def mip_chain(faces: np.ndarray) -> list[np.ndarray]:
    """All levels from `faces` down to 1x1 by repeated 2x2 box filtering."""
    levels = [np.asarray(faces, dtype=np.float32)]
    while levels[-1].shape[1] > 1:
        levels.append(box_downsample(levels[-1]))
    return levels


def sample_nearest(faces: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Nearest-texel lookup of cube faces along world directions (for tests and previews)."""
    size = faces.shape[1]
    face, s, t = direction_to_face(d)
    i = np.clip((s * size).astype(np.int64), 0, size - 1)
    j = np.clip((t * size).astype(np.int64), 0, size - 1)
    return faces[face, j, i]
