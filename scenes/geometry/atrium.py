"""A procedural, Sponza-like atrium of any size: the large scene of the voxel storage experiment.

No large architectural model is packaged here, so the atrium is generated: a square courtyard of `bays`
bays (BAY metres each) per side, ringed by two storeys of colonnades; thin walls and open space, as in
Sponza or a cloister. Every part is made by one of two constructions:

- a closed sweep: a closed section polygon swept along a path, with fan caps at both ends. Columns (a
  regular 8d-gon swept up), arches (a rectangle swept along a semicircle between two columns) and boxes
  (gallery floor slabs, balcony parapets and the outer walls: thin boxes, a subdivided rectangle swept
  along the box's longest axis) are closed, outward-facing 2-manifolds.
- a one-sided sheet: a (u, v) grid. The ground floor (facing up) and the drapes hanging in the upper
  bays (a sinusoidal curtain facing the courtyard: thin, one-sided, as Sponza's).

Winding: a sweep's section is counter-clockwise in its frame (A, B) with A x B the path's tangent T, so
the side quads' normal d(section) x d(path) points outward (a CCW polygon's outward normal is its edge
tangent x T); the start cap faces -T and the end cap +T. A grid's triangles (a, b, d), (a, d, c) over
a = (i, j), b = (i + 1, j), c = (i, j + 1), d = (i + 1, j + 1) face du x dv.

Triangle count (`triangle_count`, derived part by part, `d` = detail):
    column (8d-gon, 2d rings along its height): 2 (8d)(2d) + 2 (8d)       = 32 d^2 + 16 d, 8 b columns
    arch (4-gon along 8d segments):             2 (4)(8d) + 2 (4)          = 64 d + 8,      8 b arches
    box (4d-gon section, d segments along):     2 (4d)(d) + 2 (4d)         = 8 d^2 + 8 d,   12 boxes
    ground floor (2 d b x 2 d b grid):          2 (2 d b)^2                = 8 b^2 d^2
    drape (4d x 4d grid):                       2 (4d)^2                   = 32 d^2,        4 b drapes
  total = 384 b d^2 + 640 b d + 64 b + 8 b^2 d^2 + 96 d^2 + 96 d.
`SIZES` names (bays, detail) giving about 1e4, 1e5, 1e6 and 2e6 triangles; the courtyard (and the voxel
grid over it) grows with `bays`, the tessellation with `detail`.

The mesh is built directly as a `Mesh` (not through make_mesh, whose convexity test and welding cost
minutes at 1e6 triangles): float32 positions, per-part angle-weighted vertex normals
(meshes.smooth_normals, within each part; a box's faces and a sweep's caps have their own vertices, so
their normals are the faces'), int32 indices, `convex = closed = False` (the whole is neither).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.geometry.meshes import Mesh, smooth_normals
from scenes.storage.errors import MeshError

#: bay length (metres): column spacing along a side of the courtyard
BAY = 4.0
#: storey heights: ground colonnade 0 .. GALLERY, gallery slab GALLERY .. GALLERY + SLAB, upper colonnade to TOP
GALLERY, SLAB, TOP, WALL_HEIGHT = 4.0, 0.3, 8.0, 9.0
#: the gallery floor and the outer walls reach this far beyond the colonnade's line
AISLE = 3.0
#: named sizes: (bays, detail) -> about 1e4, 1e5, 1e6 and 2e6 triangles (exact counts: triangle_count)
SIZES = {"10k": (2, 3), "100k": (4, 7), "1M": (8, 16), "2M": (12, 18)}
UP = np.array([0.0, 1.0, 0.0])
#: outward directions of the four sides of the courtyard
SIDES = (np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0]), np.array([-1.0, 0.0, 0.0]))


@dataclass(frozen=True)
class Part:
    name: str
    positions: np.ndarray  # (V, 3) float64
    indices: np.ndarray  # (F, 3) int64
    closed: bool  # a closed, outward-facing 2-manifold (else a one-sided sheet)


def triangle_count(bays: int, detail: int) -> int:
    """The atrium's triangle count (the module docstring's table)."""
    b, d = bays, detail
    return 384 * b * d * d + 640 * b * d + 64 * b + 8 * b * b * d * d + 96 * d * d + 96 * d


def _check(bays: int, detail: int) -> None:
    for key, value in (("bays", bays), ("detail", detail)):
        if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or not 1 <= value <= 64:
            raise MeshError(f"atrium: {key} = {value!r}: must be a whole number in 1 .. 64")


def _grid_triangles(nu: int, nv: int, offset: int = 0) -> np.ndarray:
    """Triangles of a (nu + 1) x (nv + 1) vertex grid, vertex (i, j) at i (nv + 1) + j, facing du x dv."""
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = (i * (nv + 1) + j).reshape(-1)
    b, c = a + nv + 1, a + 1
    d = b + 1
    return np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)]) + offset


def sweep(name: str, section: np.ndarray, path: np.ndarray, frame_a: np.ndarray, frame_b: np.ndarray) -> Part:
    """A closed tube: the CCW section polygon (k, 2) in the frame (A_j, B_j) at each path point (m + 1, 3),
    A_j x B_j along the path; sides (k x m quads, the ring closed by repeating its first vertex) and two fan
    caps around the section's centroid: 2 k m + 2 k triangles."""
    k, m = len(section), len(path) - 1
    ring = np.concatenate([section, section[:1]])  # k + 1 vertices, the seam repeated
    side = (path[None, :, :] + ring[:, None, 0:1] * frame_a[None, :, :] + ring[:, None, 1:2] * frame_b[None, :, :])
    p_side = side.reshape(-1, 3)  # vertex (i, j) at i (m + 1) + j
    tris = [_grid_triangles(k, m)]
    centroid = section.mean(axis=0)
    caps = []
    for j, facing in ((0, -1), (m, 1)):
        base = len(p_side) + sum(len(c) for c in caps)
        centre = path[j] + centroid[0] * frame_a[j] + centroid[1] * frame_b[j]
        rim = path[j] + section[:, 0:1] * frame_a[j] + section[:, 1:2] * frame_b[j]
        caps.append(np.concatenate([centre[None], rim]))
        r0 = base + 1 + np.arange(k)
        r1 = base + 1 + (np.arange(k) + 1) % k
        c = np.full(k, base)
        tris.append(np.stack([c, r0, r1], 1) if facing > 0 else np.stack([c, r1, r0], 1))
    return Part(name, np.concatenate([p_side] + caps), np.concatenate(tris), True)


def column(name: str, foot: np.ndarray, radius: float, height: float, detail: int) -> Part:
    k, m = 8 * detail, 2 * detail
    phi = 2 * np.pi * np.arange(k) / k
    section = radius * np.stack([np.cos(phi), np.sin(phi)], 1)
    path = foot + np.linspace(0.0, height, m + 1)[:, None] * UP
    # A x B = Z x X = +Y, the path's direction
    return sweep(name, section, path, np.tile([0.0, 0.0, 1.0], (m + 1, 1)), np.tile([1.0, 0.0, 0.0], (m + 1, 1)))


def arch(name: str, centre: np.ndarray, along: np.ndarray, radius: float, thick: float, depth: float,
         detail: int) -> Part:
    """A semicircular arch of centre-line radius `radius` in the vertical plane through `along`; its
    section `thick` radially by `depth` across. Path r(t) = centre + radius (cos t along + sin t up),
    t in [0, pi]: tangent T = -sin t along + cos t up = (along x up) x rhat, so A = along x up, B = rhat."""
    m = 8 * detail
    t = np.linspace(0.0, np.pi, m + 1)[:, None]
    rhat = np.cos(t) * along + np.sin(t) * UP
    depth_axis = np.tile(np.cross(along, UP), (m + 1, 1))
    section = np.array([[-depth / 2, -thick / 2], [depth / 2, -thick / 2], [depth / 2, thick / 2],
                        [-depth / 2, thick / 2]])
    return sweep(name, section, centre + radius * rhat, depth_axis, rhat)


def box(name: str, lo, hi, detail: int) -> Part:
    """An axis-aligned box swept along its longest axis p (A, B the next axes cyclically: e_A x e_B = e_p),
    each section side and the path cut into `detail` segments."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    p = int(np.argmax(hi - lo))
    a, b = (p + 1) % 3, (p + 2) % 3
    s = np.linspace(0.0, 1.0, detail + 1)[:-1]
    (a0, a1), (b0, b1) = (lo[a], hi[a]), (lo[b], hi[b])
    # counter-clockwise in (A, B): bottom edge, right, top, left
    section = np.concatenate([np.stack([a0 + s * (a1 - a0), np.full_like(s, b0)], 1),
                              np.stack([np.full_like(s, a1), b0 + s * (b1 - b0)], 1),
                              np.stack([a1 - s * (a1 - a0), np.full_like(s, b1)], 1),
                              np.stack([np.full_like(s, a0), b1 - s * (b1 - b0)], 1)])
    path = np.zeros((detail + 1, 3))
    path[:, p] = np.linspace(lo[p], hi[p], detail + 1)
    ea, eb = np.eye(3)[a], np.eye(3)[b]
    return sweep(name, section, path, np.tile(ea, (detail + 1, 1)), np.tile(eb, (detail + 1, 1)))


def sheet(name: str, corner: np.ndarray, du: np.ndarray, dv: np.ndarray, nu: int, nv: int,
          offset=None) -> Part:
    """A one-sided grid corner + u du + v dv (u, v in [0, 1]), plus offset(u, v) (N, 3); faces du x dv."""
    u, v = np.meshgrid(np.linspace(0.0, 1.0, nu + 1), np.linspace(0.0, 1.0, nv + 1), indexing="ij")
    u, v = u.reshape(-1, 1), v.reshape(-1, 1)
    p = corner + u * du + v * dv
    if offset is not None:
        p = p + offset(u, v)
    return Part(name, p, _grid_triangles(nu, nv), False)


def parts(bays: int, detail: int) -> list[Part]:
    """Every part of the atrium of `bays` bays per side at tessellation `detail`."""
    _check(bays, detail)
    d, a = detail, bays * BAY / 2.0  # a: half-size of the courtyard (the columns' line)
    out: list[Part] = []
    storeys = ((0.0, GALLERY, 0.3), (GALLERY + SLAB, TOP, 0.25))  # (foot, top, column radius)
    for s, o in enumerate(SIDES):
        t = np.cross(UP, o)  # along the side; t x up = o
        for i in range(bays):
            for f, (foot, top, radius) in enumerate(storeys):
                base = a * o + (-a + i * BAY) * t
                out.append(column(f"column_{f}_{s}_{i}", base + foot * UP, radius, top - foot, d))
                r, thick = BAY / 2.0, 0.3
                centre = a * o + (-a + (i + 0.5) * BAY) * t + (top - r - thick / 2) * UP
                out.append(arch(f"arch_{f}_{s}_{i}", centre, t, r, thick, 0.5, d))
            # a drape in the upper bay, hanging from just under the top, a sinusoid of 3 waves toward o
            width, drop = BAY - 0.8, TOP - GALLERY - SLAB - 1.0
            corner = (a + 0.3) * o + (-a + i * BAY + 0.4) * t + (TOP - 0.2) * UP
            out.append(sheet(f"drape_{s}_{i}", corner, width * t, -drop * UP, 4 * d, 4 * d,
                             lambda u, v, o=o: 0.15 * np.sin(6 * np.pi * u) * o))
    outer = a + AISLE
    for s, o in enumerate(SIDES):
        t = np.cross(UP, o)
        for name, near, far, y0, y1, half in (("slab", a - 1.0, outer, GALLERY, GALLERY + SLAB, outer),
                                              ("parapet", a - 0.65, a - 0.55, GALLERY + SLAB, GALLERY + SLAB + 1.0,
                                               a - 0.55),
                                              ("wall", outer, outer + 0.2, 0.0, WALL_HEIGHT, outer + 0.2)):
            c0, c1 = near * o - half * t + y0 * UP, far * o + half * t + y1 * UP
            out.append(box(f"{name}_{s}", np.minimum(c0, c1), np.maximum(c0, c1), d))
    n = 2 * d * bays
    out.append(sheet("ground", np.array([-outer, 0.0, -outer]), np.array([0.0, 0.0, 2 * outer]),
                     np.array([2 * outer, 0.0, 0.0]), n, n))
    return out


def atrium(bays: int, detail: int) -> Mesh:
    """The atrium as one Mesh (triangle_count(bays, detail) triangles)."""
    ps = parts(bays, detail)
    offsets = np.cumsum([0] + [len(p.positions) for p in ps])
    positions = np.concatenate([p.positions for p in ps])
    indices = np.concatenate([p.indices + off for p, off in zip(ps, offsets[:-1], strict=True)])
    normals = np.concatenate([smooth_normals(p.positions, p.indices) for p in ps])
    return Mesh(f"atrium-{bays}x{detail}", positions.astype(np.float32), normals.astype(np.float32),
                indices.astype(np.int32), convex=False, closed=False)


def atrium_of_size(size: str) -> Mesh:
    """The atrium of a named size (SIZES: 10k, 100k, 1M, 2M)."""
    if size not in SIZES:
        raise MeshError(f"atrium size {size!r}: must be one of {', '.join(SIZES)}, or BAYSxDETAIL (e.g. 4x2)")
    return atrium(*SIZES[size])
