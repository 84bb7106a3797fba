"""Directions on the sphere: the equirectangular (lat-long) map and rotations about +Y.

Convention (docs/contract.md section 2, Mitsuba's `envmap`): world is right-handed, +Y up, and a
direction d maps to

    u = atan2(d.x, -d.z) / (2 pi)   in [0, 1)   (u = 0 is -Z, u = 0.25 is +X, u = 0.5 is +Z)
    v = acos(d.y) / pi              in [0, 1]   (v = 0 is +Y, the top row)

An equirect image of H x W pixels is sampled by Mitsuba at `col = u * W - 0.5` (wrapping) and
`row = v * (H - 1)` (rows are align-corners: row 0 sits exactly on the +Y pole, row H-1 on -Y).
So pixel (row r, col c) *is* the radiance at u = (c + 0.5) / W, v = r / (H - 1).

All functions work on arrays of shape (..., 3) and compute in float64.
"""

from __future__ import annotations

import numpy as np

TWO_PI = 2.0 * np.pi


def normalize(v: np.ndarray, eps: float = 0.0) -> np.ndarray:
    """Unit vectors along the last axis; zero vectors stay zero (never NaN)."""
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, n, out=np.zeros_like(v), where=n > eps)


def direction_to_uv(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mitsuba's envmap (u, v) of world directions d (..., 3); u in [0, 1), v in [0, 1]."""
    d = normalize(d)
    # "+ 0.0" turns -0.0 into +0.0: at the poles (x = z = 0) u is then atan2(0, 0) = 0, as in drjit
    u = np.arctan2(d[..., 0] + 0.0, -d[..., 2] + 0.0) / TWO_PI
    u = u - np.floor(u)
    v = np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / np.pi
    return u, v


def uv_to_direction(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Inverse of `direction_to_uv`: unit directions (..., 3)."""
    phi, theta = np.broadcast_arrays(TWO_PI * np.asarray(u, dtype=np.float64), np.pi * np.asarray(v, dtype=np.float64))
    s = np.sin(theta)
    return np.stack([s * np.sin(phi), np.cos(theta), -s * np.cos(phi)], axis=-1)


def equirect_directions(height: int, width: int) -> np.ndarray:
    """World directions (H, W, 3) of the sample points of an H x W equirect map.

    Pixel (r, c) sits at u = (c + 0.5) / W, v = r / (H - 1) (see the module docstring).
    """
    if height < 2 or width < 1:
        raise ValueError(f"an equirect map needs at least 2 rows and 1 column, got {height}x{width}")
    u = (np.arange(width) + 0.5) / width
    v = np.arange(height) / (height - 1)
    return uv_to_direction(u[None, :], v[:, None])


def equirect_solid_angles(height: int, width: int) -> np.ndarray:
    """Quadrature weights (H, W) in steradians for the samples of `equirect_directions`.

    Row r stands for the band of polar angle [theta_r - dt/2, theta_r + dt/2] clipped to [0, pi]
    with theta_r = pi r / (H - 1) (half bands at the poles), times 2 pi / W in azimuth. The
    weights are exact band areas and sum to 4 pi.
    """
    dt = np.pi / (height - 1)
    theta = np.arange(height) * dt
    lo = np.clip(theta - dt / 2, 0.0, np.pi)
    hi = np.clip(theta + dt / 2, 0.0, np.pi)
    band = np.cos(lo) - np.cos(hi)
    return np.repeat((band * TWO_PI / width)[:, None], width, axis=1)


def rotation_y(deg: float) -> np.ndarray:
    """3x3 right-handed rotation about +Y by `deg` degrees.

    Same matrix as Mitsuba's `ScalarTransform4f().rotate([0, 1, 0], deg)`:
    [[c, 0, s], [0, 1, 0], [-s, 0, c]].
    """
    t = np.radians(deg)
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rotation_xyz(deg_xyz) -> np.ndarray:
    """3x3 rotation applying X, then Y, then Z rotations (degrees), as object transforms do."""
    ax, ay, az = np.radians(np.asarray(deg_xyz, dtype=np.float64))
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def to_environment_frame(d: np.ndarray, rotation_deg: float) -> np.ndarray:
    """World direction -> the map's own frame, for a map turned by `rotation_deg` about +Y.

    The environment is placed with to_world = rotation_y(rotation_deg), so a lookup applies the
    inverse (the transpose) to the world direction first.
    """
    if rotation_deg == 0.0:
        return np.asarray(d, dtype=np.float64)
    return np.asarray(d, dtype=np.float64) @ rotation_y(rotation_deg)  # row-vector form of R^T d


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Rec. 709 / sRGB-primaries luminance of linear RGB (..., 3)."""
    rgb = np.asarray(rgb)
    return 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]
