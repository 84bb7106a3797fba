"""glTF's axes (iblcheck's world: right-handed, +Y up) -> Blender's (right-handed, +Z up), and Blender's
equirect lookup in those axes.

The axis change is the glTF importer's: (x, y, z)_gltf -> (x, -z, y)_blender, a proper rotation (+90 degrees
about X, determinant 1), so handedness, angles and rotation senses are kept: a rotation by theta about
glTF's +Y is the rotation by theta about Blender's +Z.

Blender's Environment Texture, equirectangular (Cycles `direction_to_equirectangular_range` with the
default range (-2 pi, pi, -pi, pi/2)), for a Blender direction D:

    u = -atan2(D.y, D.x) / (2 pi) + 0.5,   v = atan2(D.z, hypot(D.x, D.y)) / pi + 0.5   (v = 1 the image's top)

With D = (x, -z, y) of a glTF direction d: u = atan2(d.z, d.x) / (2 pi) + 0.5 and
v = 0.5 + (pi/2 - acos(d.y)) / pi = 1 - acos(d.y) / pi, i.e. acos(d.y) / pi from the top: exactly the
viewers' convention the export's .hdr is written in (three.js `equirectUv`). Texel centres: Cycles'
bilinear lookup reads x = u W - 0.5 (texel centres at (c + 0.5) / W, rows alike), as the export's.
"""

from __future__ import annotations

import math

import numpy as np

#: row-vector convention: d_blender = d_gltf @ GLTF_TO_BLENDER.T
GLTF_TO_BLENDER = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def to_blender(v: np.ndarray) -> np.ndarray:
    """glTF vectors or points (..., 3) in Blender's axes, (x, -z, y): a permutation and a sign, so exact and
    of the input's dtype (float32 mesh arrays stay bit for bit the exported values)."""
    v = np.asarray(v)
    return np.stack([v[..., 0], -v[..., 2], v[..., 1]], axis=-1)


def look_at_basis(origin, target, up) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orthonormal (right, true_up, forward) of a gluLookAt camera in glTF axes: forward = target - origin,
    right = forward x up, true_up = right x forward (iblcheck's camera; the sidecar's position, target, up)."""
    forward = np.subtract(target, origin).astype(np.float64)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.asarray(up, dtype=np.float64))
    right /= np.linalg.norm(right)
    return right, np.cross(right, forward), forward


def camera_to_world(origin, target, up) -> np.ndarray:
    """4x4 camera -> world in Blender's axes for a Blender camera object.

    A Blender camera, like glTF's and OpenGL's, looks down its local -Z with +Y up on the image and +X to the
    right; so its columns are (right, true_up, -forward, origin) of the gluLookAt basis, each turned into
    Blender's axes. Its rays are then iblcheck's pixel rays.
    """
    right, true_up, forward = look_at_basis(origin, target, up)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = to_blender(right), to_blender(true_up), to_blender(-forward)
    m[:3, 3] = to_blender(np.asarray(origin, dtype=np.float64))
    return m


def equirect_uv(d_blender: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Blender's equirect (u, v) of Blender directions (..., 3); v = 1 at the image's top row."""
    d = np.asarray(d_blender, dtype=np.float64)
    u = -np.arctan2(d[..., 1], d[..., 0]) / (2.0 * math.pi) + 0.5
    v = np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1])) / math.pi + 0.5
    return u, v


def mapping_rotation(rotation_y_deg: float) -> tuple[float, float, float]:
    """Euler XYZ rotation (radians) of a Mapping node of type POINT between the world's direction and the
    Environment Texture, for the sidecar's `rotation_y_deg` theta.

    The sidecar: radiance from world direction d is the map's at R_y(-theta) d (Mitsuba's
    `rotate([0, 1, 0], theta)` as to_world). A POINT mapping outputs R(euler) D, and R_y(-theta) in glTF
    axes is R_z(-theta) in Blender's (see the module docstring), so the Z angle is -theta.
    """
    return (0.0, 0.0, -math.radians(float(rotation_y_deg)))
