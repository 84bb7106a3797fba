"""What the disc-shaped environment parameterizations share: texel grids on [-1, 1]^2 whose useful
part is the unit disc (the dual paraboloid's two maps, the sphere map), and the exact integral of a
radial density over each texel clipped to the disc.

A map of `size` x `size` texels covers the plane square [-1, 1]^2: texel (row j, column i) has its
centre at x = 2 (i + 0.5) / size - 1, y = 2 (j + 0.5) / size - 1 (row 0 at y = -1, which OpenGL
uploads first, as t = 0: the cube map's rule). Texture coordinates are s = (x + 1) / 2, t = (y + 1) / 2.

Exact texel solid angles (`clipped_integrals`): for a density dOmega/dA = rho(r) that depends only on
r = |(x, y)|, pick g with 2 g(r) + r g'(r) = rho(r); then the 1-form w = g(r) (x dy - y dx) has
dw = rho dx dy, and by Green's theorem the solid angle of (texel ∩ disc) is the integral of w along
that region's boundary, counter-clockwise: the texel's edges clipped to the disc (on a straight edge
P -> Q, x dy - y dx = (P x Q) dt, so each edge is (P x Q) times a 1D integral of g along it) plus the
arcs of the unit circle inside the texel (there w = g(1) dtheta). Texels outside the disc weigh zero.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

TWO_PI = 2.0 * np.pi


def texel_centres(size: int) -> np.ndarray:
    """Plane coordinates of texel centres along one axis: 2 (k + 0.5) / size - 1."""
    return 2.0 * (np.arange(size) + 0.5) / size - 1.0


def texel_positions(size: int) -> tuple[np.ndarray, np.ndarray]:
    """(x, y), each (size, size): x varies along columns, y along rows."""
    c = texel_centres(size)
    return np.meshgrid(c, c, indexing="xy")


def position_to_texture(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plane position -> texture coordinates (s, t) in [0, 1]."""
    return (np.asarray(x) + 1.0) / 2.0, (np.asarray(y) + 1.0) / 2.0


def position_to_texel(x: np.ndarray, y: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """(row, column) of the texel that holds each plane position (nearest-texel lookup)."""
    s, t = position_to_texture(x, y)
    col = np.clip(np.floor(s * size).astype(np.int64), 0, size - 1)
    row = np.clip(np.floor(t * size).astype(np.int64), 0, size - 1)
    return row, col


def full_texels(size: int) -> np.ndarray:
    """(size, size) bool: texels entirely inside the unit disc (all four corners within it)."""
    e = np.linspace(-1.0, 1.0, size + 1)
    x0, y0 = np.meshgrid(e[:-1], e[:-1], indexing="xy")
    far_x = np.maximum(np.abs(x0), np.abs(x0 + 2.0 / size))
    far_y = np.maximum(np.abs(y0), np.abs(y0 + 2.0 / size))
    return far_x ** 2 + far_y ** 2 <= 1.0


def _segment(px, py, qx, qy, line_integral) -> np.ndarray:
    """Integral of w along P -> Q, the part inside the unit disc."""
    dx, dy = qx - px, qy - py
    a = dx * dx + dy * dy
    b = 2.0 * (px * dx + py * dy)
    c = px * px + py * py
    disc = b * b - 4.0 * a * (c - 1.0)
    root = np.sqrt(np.maximum(disc, 0.0))
    t0 = np.clip((-b - root) / (2.0 * a), 0.0, 1.0)
    t1 = np.clip((-b + root) / (2.0 * a), 0.0, 1.0)
    inside = (disc > 0.0) & (t1 > t0)
    t1 = np.where(inside, t1, t0)
    cross = px * qy - py * qx
    return np.where(inside, cross * line_integral(a, b, c, t0, t1), 0.0)


def _arc_length_inside(x0, x1, y0, y1) -> np.ndarray:
    """Total angle of the unit circle inside each rectangle [x0, x1] x [y0, y1]."""
    cands = []
    for xv in (x0, x1):
        ok = np.abs(xv) <= 1.0
        a = np.arccos(np.clip(xv, -1.0, 1.0))
        cands += [np.where(ok, a, np.inf), np.where(ok, TWO_PI - a, np.inf)]
    for yv in (y0, y1):
        ok = np.abs(yv) <= 1.0
        a = np.arcsin(np.clip(yv, -1.0, 1.0))
        cands += [np.where(ok, np.mod(a, TWO_PI), np.inf), np.where(ok, np.pi - a, np.inf)]
    ang = np.sort(np.stack(cands, axis=-1), axis=-1)
    n = np.sum(np.isfinite(ang), axis=-1)
    ang = np.where(np.isfinite(ang), ang, 0.0)  # unused slots (k >= n) are masked below
    first = ang[..., 0]
    total = np.zeros(np.shape(x0))
    for k in range(ang.shape[-1]):
        valid = k < n
        start = ang[..., k]
        nxt = ang[..., k + 1] if k + 1 < ang.shape[-1] else start
        end = np.where(k + 1 < n, nxt, first + TWO_PI)  # the last interval wraps to the first angle
        mid = 0.5 * (start + end)
        cx, cy = np.cos(mid), np.sin(mid)
        inside = valid & (cx > x0) & (cx < x1) & (cy > y0) & (cy < y1)
        total = total + np.where(inside, end - start, 0.0)
    # no crossing at all: the circle is wholly inside the rectangle or wholly outside it
    whole = (n == 0) & (x0 < -1.0) & (x1 > 1.0) & (y0 < -1.0) & (y1 > 1.0)
    return np.where(whole, TWO_PI, total)


def clipped_integrals(size: int, line_integral: Callable, g_rim: float) -> np.ndarray:
    """(size, size): the integral of a radial density over each texel ∩ the unit disc (module docstring).

    `line_integral(a, b, c, t0, t1)` is the integral of g(r(t)) dt from t0 to t1 with
    r(t)^2 = a t^2 + b t + c; `g_rim` = g(1)."""
    e = np.linspace(-1.0, 1.0, size + 1)
    x0, y0 = np.meshgrid(e[:-1], e[:-1], indexing="xy")
    x1, y1 = np.meshgrid(e[1:], e[1:], indexing="xy")
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]  # counter-clockwise
    total = np.zeros((size, size))
    for k in range(4):
        (px, py), (qx, qy) = corners[k], corners[(k + 1) % 4]
        total += _segment(px, py, qx, qy, line_integral)
    return total + g_rim * _arc_length_inside(x0, x1, y0, y1)


def jacobian_singular_values(position_to_direction: Callable, x: np.ndarray, y: np.ndarray,
                             h: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """(largest, smallest) singular value of d(direction)/d(x, y) by central differences: the local
    stretch of a map from the plane to the sphere (equal when the map is conformal; their product is
    dOmega/dA)."""
    dx = (position_to_direction(x + h, y) - position_to_direction(x - h, y)) / (2 * h)
    dy = (position_to_direction(x, y + h) - position_to_direction(x, y - h)) / (2 * h)
    e = np.sum(dx * dx, -1)
    f = np.sum(dx * dy, -1)
    g = np.sum(dy * dy, -1)
    mean, diff = 0.5 * (e + g), np.sqrt(0.25 * (e - g) ** 2 + f * f)
    return np.sqrt(mean + diff), np.sqrt(np.maximum(mean - diff, 0.0))
