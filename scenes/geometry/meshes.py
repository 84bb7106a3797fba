"""Triangle meshes shared by both renderers: builtin shapes, mesh files (through trimesh), normals.

A `Mesh` is an indexed triangle list with one unit normal per vertex (float32, so both
renderers draw bit-identical geometry), counter-clockwise winding seen from outside, and a
`convex` flag (a convex object cannot shadow or reflect onto itself, docs/contract.md section 4).
Builtin meshes are centred at the origin and fit in the unit sphere (`sphere` has radius 1).
"""

from __future__ import annotations

import dataclasses
import io
import logging
import re
import warnings
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull, QhullError, cKDTree

from scenes.environment.directions import normalize, rotation_xyz
from scenes.geometry import gltf_check
from scenes.storage.errors import MeshError
from scenes.storage.files import read_input

#: vertex coordinates in a mesh file must lie within +- this (objects.scale enlarges an object)
MAX_COORDINATE = 1e6


class MeshWarning(UserWarning):
    """A mesh was repaired on load (e.g. inward normals flipped)."""


@dataclass(frozen=True, eq=False)
class Mesh:
    name: str
    positions: np.ndarray  # (V, 3) float32
    normals: np.ndarray  # (V, 3) float32, unit length
    indices: np.ndarray  # (F, 3) int32, counter-clockwise seen from outside
    convex: bool
    closed: bool = field(default=False)

    @property
    def n_triangles(self) -> int:
        return int(self.indices.shape[0])

    def transformed(self, scale: float, rotate_deg, translate) -> Mesh:
        """Scale, then rotate about X, Y, Z (degrees), then translate (docs/contract.md section 2)."""
        r = rotation_xyz(rotate_deg)
        p = (self.positions.astype(np.float64) * scale) @ r.T + np.asarray(translate, dtype=np.float64)
        n = normalize(self.normals.astype(np.float64) @ r.T)
        return Mesh(self.name, p.astype(np.float32), n.astype(np.float32), self.indices, self.convex, self.closed)

    def bounding_radius(self) -> float:
        return float(np.linalg.norm(self.positions, axis=1).max())

    def face_normals(self) -> np.ndarray:
        """Unnormalised face normals (F, 3), length = twice the triangle area."""
        p = self.positions.astype(np.float64)
        a, b, c = p[self.indices[:, 0]], p[self.indices[:, 1]], p[self.indices[:, 2]]
        return np.cross(b - a, c - a)


#: objects.normals: where a mesh's per-vertex normals come from (make_mesh)
NORMALS = ("auto", "file", "smooth", "flat")


def make_mesh(name: str, positions, indices, normals=None, convex: bool | None = None,
              closed: bool | None = None, shading: str = "auto", crease_deg: float | None = None) -> Mesh:
    """Build a validated Mesh: finite coordinates within +-MAX_COORDINATE, indices in range, zero-area
    triangles dropped (an error when none is left); then its normals, by `shading`:

    - "file": the given normals (a builtin shape's analytic ones, a file's own); an error when there are
      none. A zero-length one is replaced by the smooth normal, an inward one (against its faces'
      winding) is flipped, with a MeshWarning.
    - "smooth": angle-weighted face normals averaged over the vertices at one position (welded, so
      seams and unshared corners smooth too); with `crease_deg`, faces that meet at an edge at more than
      that angle are not averaged together: the vertices there split (hard edges).
    - "flat": every triangle its own three vertices with its face normal.
    - "auto" (the default): "file" when normals are given, else "smooth" (without a crease angle).
    """
    if shading not in NORMALS:
        raise MeshError(f"{name}: normals = {shading!r}: must be one of {', '.join(NORMALS)}")
    p = np.asarray(positions, dtype=np.float64)
    idx = np.asarray(indices, dtype=np.int64).reshape(-1, 3)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0:
        raise MeshError(f"{name}: no vertices")
    if not np.isfinite(p).all():
        raise MeshError(f"{name}: vertex positions contain NaN or Inf")
    if np.abs(p).max() > MAX_COORDINATE:
        raise MeshError(f"{name}: vertex coordinates reach {np.abs(p).max():.3g}; they must lie within "
                        f"+-{MAX_COORDINATE:g} (scale the object with objects.scale instead)")
    if len(idx) == 0 or idx.min() < 0 or idx.max() >= len(p):
        raise MeshError(f"{name}: triangle indices out of range (0..{len(p) - 1})")
    # drop degenerate (zero-area) triangles: they carry no surface and no normal
    fn = np.cross(p[idx[:, 1]] - p[idx[:, 0]], p[idx[:, 2]] - p[idx[:, 0]])
    area2 = np.linalg.norm(fn, axis=1)
    keep = area2 > 1e-12 * max(1.0, float(np.abs(p).max()) ** 2)
    if not keep.any():
        raise MeshError(f"{name}: every triangle is degenerate (zero area)")
    idx = idx[keep]
    if shading == "file" and normals is None:
        raise MeshError(f'{name}: normals = "file", but it has no vertex normals (STL and OFF files never do); '
                        'use normals = "smooth" (crease_deg for hard edges) or "flat"')
    if shading == "flat":
        p, idx, n = flat_shaded(p, idx)
    elif shading == "smooth" or normals is None:
        p, idx, n = smooth_shaded(p, idx, crease_deg)
    else:
        smooth = smooth_normals(p, idx)
        n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        if n.shape != p.shape:
            raise MeshError(f"{name}: {len(n)} normals for {len(p)} vertices")
        n = np.nan_to_num(n, nan=0.0, posinf=0.0, neginf=0.0)
        length = np.linalg.norm(n, axis=1)
        n = np.where((length > 1e-12)[:, None], normalize(n), smooth)
        # a normal pointing against its faces' winding (an inward normal) is flipped, and said so
        inward = (n * smooth).sum(axis=1) < 0
        if inward.any():
            warnings.warn(f"{name}: {int(inward.sum())} vertex normals point against the faces' winding "
                          "(inward); flipped", MeshWarning, stacklevel=2)
            n[inward] *= -1.0
    if convex is None:
        convex = is_convex(p, idx)
    if closed is None:
        closed = is_closed(p, idx)
    return Mesh(name, p.astype(np.float32), n.astype(np.float32), idx.astype(np.int32), bool(convex), bool(closed))


def shaded(mesh: Mesh, shading: str, crease_deg: float | None = None) -> Mesh:
    """`mesh` with its normals made by `shading` (make_mesh); "auto" and "file" keep its own."""
    if shading in ("auto", "file"):
        return mesh
    return make_mesh(mesh.name, mesh.positions, mesh.indices, convex=mesh.convex, closed=mesh.closed,
                     shading=shading, crease_deg=crease_deg)


def _corner_angles(p: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """(F, 3) interior angle of each triangle at each corner (radians)."""
    a = p[idx]
    e1 = np.roll(a, -1, axis=1) - a
    e2 = np.roll(a, -2, axis=1) - a
    return np.arctan2(np.linalg.norm(np.cross(e1, e2), axis=-1), np.einsum("fck,fck->fc", e1, e2))


def _unit_face_normals(p: np.ndarray, idx: np.ndarray) -> np.ndarray:
    return normalize(np.cross(p[idx[:, 1]] - p[idx[:, 0]], p[idx[:, 2]] - p[idx[:, 0]]))


def _accumulate(groups: np.ndarray, n_groups: int, vectors: np.ndarray) -> np.ndarray:
    """Sum of the (N, 3) vectors per group index (N,)."""
    return np.stack([np.bincount(groups, weights=vectors[:, c], minlength=n_groups) for c in range(3)], -1)


def smooth_normals(p: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Angle-weighted average of the adjacent face normals per vertex (Thuermer & Wuethrich 1998: the
    same normal however the faces around it are triangulated); unit, zero if isolated."""
    weighted = (_corner_angles(p, idx)[..., None] * _unit_face_normals(p, idx)[:, None, :]).reshape(-1, 3)
    return normalize(_accumulate(idx.reshape(-1), len(p), weighted))


def smooth_shaded(p: np.ndarray, idx: np.ndarray, crease_deg: float | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(positions, indices, normals) with smooth normals over vertices welded by position; with
    `crease_deg` < 180, the corners around a vertex are averaged only across edges whose two faces'
    normals differ by at most that angle, and each such fan of corners gets its own vertex."""
    fn = _unit_face_normals(p, idx)
    weld = weld_ids(p)[idx]  # (F, 3) welded vertex of each corner
    if crease_deg is None or crease_deg >= 180.0:
        group = weld.reshape(-1)
    else:
        group = _crease_fans(weld, fn, float(crease_deg))
    _, first, label = np.unique(group, return_index=True, return_inverse=True)
    weighted = (_corner_angles(p, idx)[..., None] * fn[:, None, :]).reshape(-1, 3)
    acc = _accumulate(label, len(first), weighted)
    length = np.linalg.norm(acc, axis=1)
    # where opposite faces cancel (a folded sheet), the first corner's face normal
    n = np.where((length > 1e-12)[:, None], acc / np.maximum(length, 1e-300)[:, None], fn[first // 3])
    return p[idx.reshape(-1)[first]], label.reshape(-1, 3), n


def _crease_fans(weld: np.ndarray, fn: np.ndarray, crease_deg: float) -> np.ndarray:
    """A fan label per corner (3F,): corners at one welded vertex share a label when their faces are
    connected around it through edges at which the faces' normals differ by at most crease_deg."""
    n_corners = weld.size
    entry = np.arange(n_corners)  # edge entry e: face e // 3, from its corner e to the next corner
    face, nxt = entry // 3, entry - entry % 3 + (entry % 3 + 1) % 3
    a, b = weld.reshape(-1), weld.reshape(-1)[nxt]
    n_w = int(weld.max()) + 1
    key = np.minimum(a, b) * n_w + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    same = key[order][1:] == key[order][:-1]  # consecutive entries on one edge (a non-manifold edge: a chain)
    e1, e2 = order[:-1][same], order[1:][same]
    smooth = np.einsum("ek,ek->e", fn[face[e1]], fn[face[e2]]) >= np.cos(np.radians(crease_deg))
    e1, e2 = e1[smooth], e2[smooth]
    aligned = a[e1] == a[e2]  # both faces run along the edge the same way (else opposite: the usual case)
    src = np.concatenate([e1, nxt[e1]])
    dst = np.concatenate([np.where(aligned, e2, nxt[e2]), np.where(aligned, nxt[e2], e2)])
    graph = coo_matrix((np.ones(len(src), np.int8), (src, dst)), shape=(n_corners, n_corners))
    return connected_components(graph, directed=False)[1]


def flat_shaded(p: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(positions, indices, normals): three vertices per triangle, each with the face normal."""
    return p[idx.reshape(-1)], np.arange(idx.size).reshape(-1, 3), np.repeat(_unit_face_normals(p, idx), 3, axis=0)


def weld_ids(p: np.ndarray) -> np.ndarray:
    """One id per vertex position: vertices within 1e-6 of the largest coordinate share one."""
    q = np.round(np.asarray(p, dtype=np.float64) / (1e-6 * max(1e-12, float(np.abs(p).max()))))
    return np.unique(q, axis=0, return_inverse=True)[1].reshape(-1)


def is_closed(p: np.ndarray, idx: np.ndarray) -> bool:
    """True when every directed edge has exactly one opposite twin (a closed, consistently
    oriented 2-manifold). Vertices at the same position (creases, seams) count as one."""
    w = weld_ids(p)[idx].astype(np.int64)
    e = np.concatenate([w[:, [0, 1]], w[:, [1, 2]], w[:, [2, 0]]])
    n = int(w.max()) + 1
    keys = np.sort(e[:, 0] * n + e[:, 1])
    if (keys[1:] == keys[:-1]).any():
        return False
    twins = e[:, 1] * n + e[:, 0]
    at = np.minimum(np.searchsorted(keys, twins), len(keys) - 1)
    return bool((keys[at] == twins).all())


def _sorted_unique(a: np.ndarray) -> np.ndarray:
    """np.unique of a 1-d integer array by sorting (numpy's hash-based unique is slow on millions)."""
    a = np.sort(a)
    return a[np.r_[True, a[1:] != a[:-1]]] if len(a) else a


def is_convex(p: np.ndarray, idx: np.ndarray, rel_tol: float = 1e-6) -> bool:
    """True when no vertex lies in front of any face's plane (then the surface bounds a convex
    set and can neither occlude nor reflect onto itself).

    Only the convex hull's vertices can be in front of a plane, and the farthest of them along a
    face's normal is found by climbing the hull's edge graph (a linear function has no local maximum
    on a convex polytope's graph that is not global), starting from the face's own vertex or from
    the hull facet of nearest normal: a step or two per face, O(F log F) for the whole mesh instead
    of testing every vertex against every face."""
    p = np.asarray(p, dtype=np.float64)
    p = p - p.mean(axis=0)
    a = p[idx[:, 0]]
    fn = normalize(np.cross(p[idx[:, 1]] - a, p[idx[:, 2]] - a))
    tol = rel_tol * max(1e-12, float(np.ptp(p, axis=0).max()))
    offset = np.einsum("fk,fk->f", fn, a)
    try:
        hull = ConvexHull(p)
    except (QhullError, ValueError):  # flat or degenerate: every vertex lies on (nearly) one plane
        return _supports(p, fn, offset, tol)
    on_hull = np.zeros(len(p), bool)
    on_hull[hull.vertices] = True
    _, nearest = cKDTree(hull.equations[:, :3]).query(fn)
    start = np.where(on_hull[idx[:, 0]], idx[:, 0], hull.simplices[nearest, 0])
    return bool((_support(p, _hull_graph(hull.simplices, len(p)), fn, start) - offset <= tol).all())


def _hull_graph(triangles: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The edge graph of triangles over n points as CSR (indptr, neighbours)."""
    e = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]).astype(np.int64)
    keys = _sorted_unique(np.concatenate([e[:, 0] * n + e[:, 1], e[:, 1] * n + e[:, 0]]))  # by first vertex
    return np.searchsorted(keys // n, np.arange(n + 1)), keys % n


def _support(p: np.ndarray, graph: tuple[np.ndarray, np.ndarray], dirs: np.ndarray, start: np.ndarray) -> np.ndarray:
    """max over the graph's vertices of dirs . p per direction, by steepest ascent from `start`."""
    indptr, nbrs = graph
    cur = start.astype(np.int64).copy()
    val = np.einsum("fk,fk->f", p[cur], dirs)
    active = np.arange(len(dirs))
    while active.size:
        lo, hi = indptr[cur[active]], indptr[cur[active] + 1]
        counts = hi - lo
        owner = np.repeat(np.arange(active.size), counts)
        cand = nbrs[np.repeat(lo - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())]
        vals = np.einsum("ck,ck->c", p[cand], dirs[active[owner]])
        best = np.maximum.reduceat(vals, np.cumsum(counts) - counts)  # every hull vertex has neighbours
        better = best > val[active]
        winner = np.zeros(active.size, np.int64)
        hit = vals == best[owner]
        winner[owner[hit]] = cand[hit]
        moved = active[better]
        cur[moved], val[moved] = winner[better], best[better]
        active = moved
    return val


def _supports(points: np.ndarray, fn: np.ndarray, offset: np.ndarray, tol: float) -> bool:
    """No point lies more than tol in front of any plane (fn . x = offset), in chunks of 256 planes."""
    for start in range(0, len(fn), 256):
        if ((points @ fn[start:start + 256].T - offset[start:start + 256]) > tol).any():
            return False
    return True


# --------------------------------------------------------------------------- builtin shapes


def sphere(resolution: int = 64) -> Mesh:
    """Unit UV sphere: `resolution` latitude bands, 2 x resolution longitudes; normals = positions."""
    n_lat, n_lon = max(2, resolution), max(3, 2 * resolution)
    theta = np.arange(1, n_lat) * np.pi / n_lat
    phi = np.arange(n_lon) * 2 * np.pi / n_lon
    t, f = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(t) * np.sin(f), np.cos(t), np.sin(t) * np.cos(f)], -1).reshape(-1, 3)
    p = np.concatenate([[[0.0, 1.0, 0.0]], ring, [[0.0, -1.0, 0.0]]])
    south = len(p) - 1

    def vid(i, j):  # ring i (0..n_lat-2), longitude j
        return 1 + i * n_lon + (j % n_lon)

    tris = []
    for j in range(n_lon):
        tris.append((0, vid(0, j), vid(0, j + 1)))
        tris.append((south, vid(n_lat - 2, j + 1), vid(n_lat - 2, j)))
        for i in range(n_lat - 2):
            a, b, c, d = vid(i, j), vid(i, j + 1), vid(i + 1, j), vid(i + 1, j + 1)
            tris += [(a, c, d), (a, d, b)]
    return make_mesh("sphere", p, np.array(tris), normals=p, convex=True)


def torus(resolution: int = 48, major: float = 0.7, minor: float = 0.3) -> Mesh:
    """Torus around +Y (ring radius `major`, tube radius `minor`; major + minor = 1)."""
    n_u, n_v = max(3, 2 * resolution), max(3, resolution)
    u = np.arange(n_u) * 2 * np.pi / n_u
    v = np.arange(n_v) * 2 * np.pi / n_v
    uu, vv = np.meshgrid(u, v, indexing="ij")
    centre = np.stack([np.sin(uu), np.zeros_like(uu), np.cos(uu)], -1)
    normal = np.cos(vv)[..., None] * centre + np.sin(vv)[..., None] * np.array([0.0, 1.0, 0.0])
    p = (major * centre + minor * normal).reshape(-1, 3)
    tris = []
    for i in range(n_u):
        for j in range(n_v):
            a, b = i * n_v + j, ((i + 1) % n_u) * n_v + j
            c, d = i * n_v + (j + 1) % n_v, ((i + 1) % n_u) * n_v + (j + 1) % n_v
            tris += [(a, b, d), (a, d, c)]
    return make_mesh("torus", p, np.array(tris), normals=normal.reshape(-1, 3), convex=False)


def plane(resolution: int = 1, half_size: float = 0.7) -> Mesh:
    """Square in the XZ plane (y = 0), normal +Y, split into resolution^2 quads."""
    n = max(1, resolution)
    c = np.linspace(-half_size, half_size, n + 1)
    x, z = np.meshgrid(c, c, indexing="xy")
    p = np.stack([x, np.zeros_like(x), z], -1).reshape(-1, 3)
    tris = []
    for i in range(n):
        for j in range(n):
            a, b, cc, d = i * (n + 1) + j, i * (n + 1) + j + 1, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1
            tris += [(a, cc, d), (a, d, b)]
    normals = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    return make_mesh("plane", p, np.array(tris), normals=normals, convex=True, closed=False)


#: bowl()'s radii: its outer and inner hemispheres
BOWL_OUTER, BOWL_INNER = 0.85, 0.75


def bowl_centre(outer: float = BOWL_OUTER) -> np.ndarray:
    """The common centre of bowl()'s two hemispheres, in its rim's plane: (0, outer / 2, 0), which centres the
    bowl's bounding box at the origin."""
    return np.array([0.0, outer / 2.0, 0.0])


def bowl(resolution: int = 48, outer: float = BOWL_OUTER, inner: float = BOWL_INNER) -> Mesh:
    """A concave hemispherical bowl (opening up, +Y) with a wall and a flat rim, closed.

    Outer hemisphere radius `outer`, inner radius `inner`, both about `bowl_centre(outer)`, which
    centres its bounding box at the origin. Not convex: it occludes and reflects onto itself.
    """
    n_lat, n_lon = max(2, resolution // 2), max(3, 2 * resolution)
    phi = np.arange(n_lon) * 2 * np.pi / n_lon
    # polar angle from the bottom pole (-Y) up to the rim (equator)
    theta = np.arange(1, n_lat + 1) * (np.pi / 2) / n_lat
    pts, nrm = [], []

    def add_surface(radius: float, sign: float):
        base = len(pts)
        pts.append([0.0, -radius, 0.0])
        nrm.append([0.0, -sign, 0.0])
        for t in theta:
            for f in phi:
                d = np.array([np.sin(t) * np.sin(f), -np.cos(t), np.sin(t) * np.cos(f)])
                pts.append(radius * d)
                nrm.append(sign * d)
        return base

    def vid(base, i, j):
        return base + 1 + i * n_lon + (j % n_lon)

    out_b = add_surface(outer, +1.0)
    in_b = add_surface(inner, -1.0)
    tris = []
    for j in range(n_lon):
        tris.append((out_b, vid(out_b, 0, j + 1), vid(out_b, 0, j)))  # outer: seen from below
        tris.append((in_b, vid(in_b, 0, j), vid(in_b, 0, j + 1)))  # inner: seen from above
        for i in range(n_lat - 1):
            a, b, c, d = vid(out_b, i, j), vid(out_b, i, j + 1), vid(out_b, i + 1, j), vid(out_b, i + 1, j + 1)
            tris += [(a, d, c), (a, b, d)]
            a, b, c, d = vid(in_b, i, j), vid(in_b, i, j + 1), vid(in_b, i + 1, j), vid(in_b, i + 1, j + 1)
            tris += [(a, c, d), (a, d, b)]
    # flat rim at y = 0 joining the two rims, normal +Y (its own vertices: a crease)
    rim_b = len(pts)
    for f in phi:
        d = np.array([np.sin(f), 0.0, np.cos(f)])
        pts += [outer * d, inner * d]
        nrm += [[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
    for j in range(n_lon):
        o0, i0 = rim_b + 2 * j, rim_b + 2 * j + 1
        o1, i1 = rim_b + 2 * ((j + 1) % n_lon), rim_b + 2 * ((j + 1) % n_lon) + 1
        tris += [(o0, o1, i1), (o0, i1, i0)]
    p = np.array(pts) + bowl_centre(outer)
    return make_mesh("bowl", p, np.array(tris), normals=np.array(nrm), convex=False)


# --------------------------------------------------------------------------- the Utah teapot


@lru_cache(maxsize=1)
def _teapot_patches() -> tuple[np.ndarray, np.ndarray]:
    text = resources.files("scenes").joinpath("data/meshes/teapot_patches.txt").read_text()
    lines = [ln.split() for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    n_pts = int(lines[0][1])
    pts = np.array(lines[1 : 1 + n_pts], dtype=np.float64)
    patches = np.array(lines[2 + n_pts :], dtype=np.int64) - 1
    return pts, patches.reshape(-1, 4, 4)


def _bernstein(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    s = 1.0 - t
    b = np.stack([s**3, 3 * t * s**2, 3 * t**2 * s, t**3], -1)
    db = np.stack([-3 * s**2, 3 * s**2 - 6 * t * s, 6 * t * s - 3 * t**2, 3 * t**2], -1)
    return b, db


def teapot(resolution: int = 12) -> Mesh:
    """The Utah teapot (Newell 1975): 32 bicubic Bezier patches tessellated at resolution^2 quads.

    Normals are the analytic patch normals (cross product of the partial derivatives), taken a
    hair inside the patch where a patch degenerates to a point (lid knob, bottom centre). Each
    patch is oriented outward (its normals point away from the centre of its corner points), the
    data's z-up frame becomes +Y up, and the result is centred and scaled into the unit sphere.
    """
    ctrl, patches = _teapot_patches()
    n = max(2, resolution)
    t = np.linspace(0.0, 1.0, n + 1)
    eps = 1e-4
    positions, normals, tris = [], [], []
    for patch in patches:
        cp = ctrl[patch]  # (4, 4, 3)
        b, db = _bernstein(t)
        pos = np.einsum("ui,vj,ijk->uvk", b, b, cp)
        du = np.einsum("ui,vj,ijk->uvk", db, b, cp)
        dv = np.einsum("ui,vj,ijk->uvk", b, db, cp)
        nrm = np.cross(du, dv)
        bad = np.linalg.norm(nrm, axis=-1) < 1e-9
        if bad.any():  # evaluate slightly inside the parameter square instead
            tn = np.clip(t, eps, 1 - eps)
            bn, dbn = _bernstein(tn)
            du2 = np.einsum("ui,vj,ijk->uvk", dbn, bn, cp)
            dv2 = np.einsum("ui,vj,ijk->uvk", bn, dbn, cp)
            nrm = np.where(bad[..., None], np.cross(du2, dv2), nrm)
        nrm = normalize(nrm)
        centre = cp[[0, 0, 3, 3], [0, 3, 0, 3]].mean(axis=0)
        flip = np.sum(nrm * (pos - centre)) < 0
        if flip:
            nrm = -nrm
        base = sum(len(x) for x in positions)
        positions.append(pos.reshape(-1, 3))
        normals.append(nrm.reshape(-1, 3))
        for i in range(n):
            for j in range(n):
                a, c = base + i * (n + 1) + j, base + (i + 1) * (n + 1) + j
                b_, d = a + 1, c + 1
                quad = [(a, c, d), (a, d, b_)] if not flip else [(a, d, c), (a, b_, d)]
                tris += quad
    p = np.concatenate(positions)
    nr = np.concatenate(normals)
    p = p[:, [0, 2, 1]] * np.array([1.0, 1.0, -1.0])  # z-up -> y-up: (x, y, z) -> (x, z, -y)
    nr = nr[:, [0, 2, 1]] * np.array([1.0, 1.0, -1.0])
    tris = np.array(tris)
    # the y-z swap with a sign flip is a proper rotation (det +1): winding is unchanged
    lo, hi = p.min(axis=0), p.max(axis=0)
    p = p - (lo + hi) / 2.0
    p = p / np.linalg.norm(p, axis=1).max() * 0.999
    # orient triangles to agree with the analytic normals (robust to the per-patch flips above)
    fn = np.cross(p[tris[:, 1]] - p[tris[:, 0]], p[tris[:, 2]] - p[tris[:, 0]])
    vn = nr[tris].sum(axis=1)
    wrong = np.einsum("ij,ij->i", fn, vn) < 0
    tris[wrong] = tris[wrong][:, [0, 2, 1]]
    return make_mesh("teapot", p, tris, normals=nr, convex=False, closed=False)


# --------------------------------------------------------------------------- shapes read from packaged files


def _packaged(name: str, shape: str) -> Mesh:
    """A mesh file shipped in scenes/data/meshes, read like any user's file (load_file), named `shape`."""
    with resources.as_file(resources.files("scenes").joinpath(f"data/meshes/{name}")) as path:
        return dataclasses.replace(load_file(path), name=shape)


def pawn(resolution: int | None = None) -> Mesh:
    """A chess pawn from pawn.glb (made by data/meshes/make_models.py): a turned profile exported
    z-up with a root node that turns it y-up into the unit sphere, and smooth normals with hard edges
    above 40 degrees in its NORMAL attribute. `resolution` has no effect (a file)."""
    return _packaged("pawn.glb", "pawn")


def rook(resolution: int | None = None) -> Mesh:
    """A chess rook from rook.stl (make_models.py): a turned body and six box merlons, binary STL, so
    without vertex normals ("auto" is flat; its scene asks for smooth with a crease angle).
    `resolution` has no effect (a file)."""
    return _packaged("rook.stl", "rook")


BUILTIN_MESHES = {"sphere": sphere, "torus": torus, "teapot": teapot, "bowl": bowl, "plane": plane,
                  "pawn": pawn, "rook": rook}
#: builtin shapes read from packaged files: no `resolution` to choose
PACKAGED_MESHES = frozenset({"pawn", "rook"})
DEFAULT_RESOLUTION = {"sphere": 64, "torus": 48, "teapot": 12, "bowl": 48, "plane": 1, "pawn": 1, "rook": 1}


#: triangles of each builtin shape at a resolution (checked against MAX_TRIANGLES before building)
BUILTIN_TRIANGLES = {"sphere": lambda r: 2 * max(3, 2 * r) * (max(2, r) - 1),
                     "torus": lambda r: 2 * max(3, 2 * r) * max(3, r),
                     "teapot": lambda r: 32 * 2 * max(2, r) ** 2,
                     "bowl": lambda r: 2 * max(3, 2 * r) * (2 * max(2, r // 2) - 1) + 2 * max(3, 2 * r),
                     "plane": lambda r: 2 * max(1, r) ** 2,
                     "pawn": lambda r: 5248, "rook": lambda r: 2504}  # the files' (tests check)


def builtin_triangles(name: str, resolution: int | None = None) -> int:
    return BUILTIN_TRIANGLES[name](resolution or DEFAULT_RESOLUTION[name])


@lru_cache(maxsize=32)
def builtin(name: str, resolution: int | None = None) -> Mesh:
    """A builtin mesh by name (cached; treat the arrays as read-only)."""
    if name not in BUILTIN_MESHES:
        raise MeshError(f"unknown builtin mesh {name!r}; choose one of {sorted(BUILTIN_MESHES)}")
    check_triangle_count(f"builtin mesh {name} at resolution {resolution or DEFAULT_RESOLUTION[name]}",
                         builtin_triangles(name, resolution))
    return BUILTIN_MESHES[name](resolution or DEFAULT_RESOLUTION[name])


# --------------------------------------------------------------------------- files

#: the most triangles a mesh may have (a file's, or a builtin shape's at its resolution): loading,
#: the convexity test and both renderers stay within seconds up to here; more is refused up front
MAX_TRIANGLES = 500_000
#: a mesh file larger than this is refused before it is read
MAX_MESH_BYTES = 512 << 20


def check_triangle_count(name: str, count: int) -> None:
    if count > MAX_TRIANGLES:
        raise MeshError(f"{name}: {count} triangles, more than the limit of {MAX_TRIANGLES}; decimate it first")



#: mesh files, read through trimesh: suffix -> trimesh's file type
MESH_FORMATS = {".obj": "obj", ".ply": "ply", ".stl": "stl", ".off": "off", ".glb": "glb", ".gltf": "gltf"}


def load_file(path: str | Path, normals: str = "auto", crease_deg: float | None = None) -> Mesh:
    """Load a mesh from .obj, .ply, .stl, .off, .glb or .gltf (every node of a glTF scene, with its
    node transform applied), shaded as `normals` says (see `make_mesh`); "auto" takes the file's vertex
    normals, and where it has none: flat for STL and glTF (AUTO_WITHOUT_NORMALS), smooth for OBJ, PLY, OFF.

    trimesh parses the file (with `process=False`: nothing merged, dropped or re-wound); what it reads
    leniently (a malformed OBJ line, a PLY face of 2 corners, relative OBJ indices) is refused here, and
    the result goes through make_mesh's checks. Every problem is a MeshError naming the file (and the
    line where there is one): no message carries Python's own text ("list index out of range")."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MESH_FORMATS:
        raise MeshError(f"{path}: unsupported mesh format {suffix!r} (use {', '.join(MESH_FORMATS)})")
    data = read_input(path, "mesh file", MAX_MESH_BYTES, MeshError)
    kind = MESH_FORMATS[suffix]
    positions, indices, file_normals = _read(path, kind, data)
    if normals == "auto" and file_normals is None:
        normals = AUTO_WITHOUT_NORMALS.get(kind, "smooth")
    return make_mesh(str(path), positions, indices, normals=file_normals, shading=normals, crease_deg=crease_deg)


#: what normals = "auto" means for a file without vertex normals, where it is not "smooth": STL holds
#: facets (no shared corners, no vertex normals), and glTF 2.0 says that "when normals are not specified,
#: client implementations MUST calculate flat normals"
AUTO_WITHOUT_NORMALS = {"stl": "flat", "glb": "flat", "gltf": "flat"}


def _read(path: Path, kind: str, data: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(positions, triangle indices, vertex normals or None) of a mesh file, in the file's frame (glTF:
    the scene's), checked against what the file says it holds."""
    uses_normals = False
    if kind == "obj":
        data, faces, uses_normals = _obj_prepare(path, data)
    elif kind == "ply":
        faces = _ply_faces(path, data)
    elif kind == "stl":
        faces = _stl_faces(path, data)
    elif kind == "off":
        faces = _off_faces(data)
    else:
        gltf_check.check(path, kind, data)  # the specification's structure, before trimesh's lenient reading
        faces = 0
    check_triangle_count(str(path), faces)  # at least one triangle per face: refused before parsing
    try:
        scene = _trimesh_scene(path, kind, data)
    except MeshError:
        if kind == "obj":  # trimesh says only "index out of bounds": name the line
            _obj_walk(path, data.decode("utf-8"))
        raise
    positions, indices, normals = _flatten(path, scene)
    if len(indices) < faces:
        raise MeshError(f"{path}: the file holds {faces} faces, only {len(indices)} triangles were read (a face "
                        "with fewer than 3 corners, or the file is cut short)")
    if uses_normals and normals is None:
        raise MeshError(f"{path}: the faces refer to vertex normals (vn) that the file does not have")
    return positions, indices, normals


#: what a trimesh error message means, in iblcheck's words (trimesh's messages are not shown as they
#: are: many are numpy's or Python's own, "setting an array element with a sequence")
_TRIMESH_SAYS = {"unexpected length": "its length does not match its header: cut short?",
                 "property defined before any element": "a header property before any element",
                 "could not be read to its end": "a value that is not a number",
                 "could not convert string to float": "a value that is not a number",
                 "face index outside the range": "a face refers to a vertex the file does not have",
                 "incorrect header on glb": "no GLB header",
                 "not an off file": "no OFF header"}


def _reason(exc: BaseException) -> str:
    if isinstance(exc, FileNotFoundError):  # a glTF's buffer or image
        return f"it refers to a file that is not there: {str(exc.filename or exc.args[-1])[:80]!r}"
    if type(exc).__name__ == "JSONDecodeError":
        return "its JSON is malformed"
    text = str(exc).lower()
    return next((says for phrase, says in _TRIMESH_SAYS.items() if phrase in text), "trimesh cannot parse it")


def _trimesh_scene(path: Path, kind: str, data: bytes):
    """trimesh's scene of the file: process=False, so trimesh merges, drops and re-winds nothing and
    make_mesh sees (and refuses) what the file holds; its log stays quiet."""
    import trimesh  # deferred: heavy (about 0.3 s), and only mesh files need it

    log = logging.getLogger("trimesh")
    if not log.handlers:  # without a handler, Python's last-resort handler prints trimesh's warnings
        log.addHandler(logging.NullHandler())
    options = {"obj": {"skip_materials": True, "group_material": False},
               "gltf": {"resolver": trimesh.resolvers.FilePathResolver(str(path.parent))}}.get(kind, {})
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return trimesh.load_scene(io.BytesIO(data), file_type=kind, process=False, **options)
    except MemoryError:
        raise
    except Exception as exc:  # trimesh's parsers raise anything from ValueError to KeyError on a broken file
        raise MeshError(f"{path}: not a readable {kind.upper()} file ({_reason(exc)})") from None


def _flatten(path: Path, scene) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Every triangle mesh instance of a trimesh scene in the scene's frame: positions by the node's
    world transform, normals by its inverse transpose, winding reversed where the transform mirrors.
    Normals: None when no part has any; zero rows for the parts without (make_mesh fills those)."""
    import trimesh  # deferred: heavy (about 0.3 s), and only mesh files need it

    parts, skipped = [], 0
    for node in scene.graph.nodes_geometry:
        matrix, name = scene.graph[node]
        geom = scene.geometry.get(name)
        if isinstance(geom, trimesh.Trimesh) and len(geom.faces):
            parts.append((node, np.asarray(matrix, dtype=np.float64), geom))
        else:
            skipped += 1
    check_triangle_count(str(path), sum(len(g.faces) for _, _, g in parts))  # instances count, each
    if not parts:
        raise MeshError(f"{path}: no faces")
    if skipped:
        warnings.warn(f"{path}: {skipped} point or line primitives ignored (only triangles are drawn)",
                      MeshWarning, stacklevel=3)
    positions, indices, normals, any_normals, offset = [], [], [], False, 0
    for node, matrix, geom in parts:
        v = np.asarray(geom.vertices, dtype=np.float64)
        f = np.asarray(geom.faces, dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
            raise MeshError(f"{path}: vertices of {v.shape[-1]} coordinates or faces of {f.shape[-1]} corners; "
                            "need 3 of each")
        linear = matrix[:3, :3]
        det = np.linalg.det(linear) if np.isfinite(linear).all() else 0.0
        if not abs(det) > 1e-300:
            raise MeshError(f"{path}: node {str(node)[:60]!r} has a singular or non-finite transform")
        with np.errstate(all="ignore"):
            positions.append(v @ linear.T + matrix[:3, 3])
        indices.append((f if det > 0 else f[:, ::-1]) + offset)
        # normals the file gives (trimesh keeps them in its cache; it computes them when asked otherwise)
        given = geom._cache.cache.get("vertex_normals") if "vertex_normals" in geom._cache else None
        if given is not None and np.shape(given) == v.shape:
            with np.errstate(all="ignore"):
                normals.append(np.asarray(given, dtype=np.float64) @ np.linalg.inv(linear))
            any_normals = True
        else:
            normals.append(np.zeros_like(v))
        offset += len(v)
    return np.concatenate(positions), np.concatenate(indices), np.concatenate(normals) if any_normals else None


# --------------------------------------------------------------------------- what trimesh reads leniently

_N = r"(?:[-+]?+(?:\d++(?:\.\d*+)?+|\.\d++)(?:[eE][-+]?+\d++)?+|[-+]?+(?i:nan|inf(?:inity)?))"
_I = r"[-+]?+\d++"
_OBJ_BAD_LINE = re.compile(
    rf"(?m)^(?:v(?= |$)(?!(?: ++{_N}){{3,7}} *+$)"  # a vertex: x y z, then optional w or r g b
    rf"|vn(?= |$)(?!(?: ++{_N}){{3}} *+$)"  # a normal: 3 numbers
    rf"|f(?= |$)(?!(?:(?: ++{_I}){{3,}}|(?: ++{_I}/{_I}){{3,}}|(?: ++{_I}//{_I}){{3,}}|(?: ++{_I}/{_I}/{_I}){{3,}})"
    r" *+$))[^\n]*")
_OBJ_ZERO_INDEX = re.compile(r"(?m)^f [^\n]*?(?<=[ /])[-+]?0++(?=[/ ]|$)")
_OBJ_NEGATIVE_INDEX = re.compile(r"(?m)^f [^\n]*?(?<=[ /])-\d")
_OBJ_WHAT = {"v": "a vertex needs 3 numbers (x y z, then an optional w or r g b)", "vn": "a normal needs 3 numbers",
             "f": "a face needs at least 3 corners, all of one form (v, v/t, v//n or v/t/n) with integer indices"}


def _obj_prepare(path: Path, data: bytes) -> tuple[bytes, int, bool]:
    """(the OBJ text for trimesh, its face count, whether its faces refer to normals), or a MeshError
    naming the line that trimesh would misread: a malformed v, vn or f line, an index 0. Relative
    indices are made absolute (trimesh counts them from the end of the file), texture indices are
    dropped (iblcheck reads no UVs, and trimesh would split vertices at UV seams), and when some faces
    give normals and others do not, no face's normals are used (a normal for every corner, or none)."""
    text = data.decode("latin-1").replace("\r\n", "\n").replace("\r", "\n").replace("\\\n", "").replace("\t", " ")
    if "#" in text or re.search(r"(?m)^ ", text):
        text = re.sub(r"(?m)^ +| *#[^\n]*", "", text)  # leading blanks (trimesh skips such lines), comments
    faces = len(re.findall(r"(?m)^f(?= |$)", text))
    check_triangle_count(str(path), faces)

    def fail(at: int, what: str) -> MeshError:
        line = text[at:text.find("\n", at) if text.find("\n", at) >= 0 else len(text)]
        return MeshError(f"{path}:{text.count(chr(10), 0, at) + 1}: {what}: {line[:60]!r}")

    bad = _OBJ_BAD_LINE.search(text)
    if bad:
        raise fail(bad.start(), _OBJ_WHAT[bad.group(0).split(" ", 1)[0]])
    zero = _OBJ_ZERO_INDEX.search(text)
    if zero:
        raise fail(zero.start(), "index 0 (OBJ indices count from 1, or back from -1)")
    if re.search(r"\d/[-+]?\d", text):
        text = re.sub(r"(?m)(?<=\d)/[-+]?\d+(?=/)", "/", text)  # v/t/n -> v//n
        text = re.sub(r"(?m)(?<=\d)/[-+]?\d+(?= |$)", "", text)  # v/t -> v
    with_normals = re.search(r"(?m)^f [^\n]*//", text) is not None
    if with_normals and re.search(rf"(?m)^f(?: +{_I})+ *$", text):  # some faces without normals: use none
        text, with_normals = re.sub(r"//[-+]?\d+", "", text), False
    if _OBJ_NEGATIVE_INDEX.search(text):
        text = _obj_walk(path, text, rewrite=True)
    return text.encode("utf-8"), faces, with_normals


def _obj_walk(path: Path, text: str, rewrite: bool = False) -> str:
    """Walk the face lines (v and v//n corners) line by line: a MeshError names the first one that
    refers to a vertex or normal not defined before it; with `rewrite`, relative (negative) indices
    become absolute ones (trimesh would count them back from the end of the file, not from the line).
    Used only where needed: on files with negative indices, and to name the line trimesh failed on."""
    count, out = {"v": 0, "vn": 0}, []
    for lineno, line in enumerate(text.split("\n"), 1):
        head, _, rest = line.partition(" ")
        if head in count:
            count[head] += 1
        elif head == "f":
            corners = []
            for corner in rest.split():
                fields = []
                for text_index, what in zip(corner.split("//"), ("v", "vn"), strict=False):
                    i = int(text_index)
                    k = i - 1 if i > 0 else count[what] + i
                    if not 0 <= k < count[what]:
                        noun = "vertex" if what == "v" else "normal"
                        raise MeshError(f"{path}:{lineno}: face refers to a missing {noun} ({i}; the file has "
                                        f"{count[what]} so far)")
                    fields.append(str(k + 1))
                corners.append("//".join(fields))
            line = "f " + " ".join(corners)
        if rewrite:
            out.append(line)
    return "\n".join(out) if rewrite else text


_PLY_INTEGERS = {"char", "uchar", "short", "ushort", "int", "uint", "int8", "uint8", "int16", "uint16", "int32",
                 "uint32"}


def _ply_faces(path: Path, data: bytes) -> int:
    """The face count a PLY header states (MeshError for a header trimesh would misread). In an ASCII
    body, the face lines must hold integers (trimesh would read 2.5 as 2)."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise MeshError(f"{path}: not a PLY file (no 'ply' signature or no 'end_header')")
    fmt, elements = None, []  # [name, count, all integer]
    for lineno, raw in enumerate(data[:end].decode("latin-1").splitlines(), 1):
        parts = raw.split()
        if parts[:1] == ["format"]:
            fmt = parts[1] if len(parts) > 1 else ""
            if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise MeshError(f"{path}: header line {lineno}: format {fmt[:40]!r} is not ascii, "
                                "binary_little_endian or binary_big_endian")
        elif parts[:1] == ["element"]:
            if len(parts) != 3 or not parts[2].isdigit():
                raise MeshError(f"{path}: header line {lineno}: expected 'element NAME COUNT'")
            elements.append([parts[1], int(parts[2]), True])
        elif parts[:1] == ["property"] and elements:
            types = parts[2:4] if parts[1:2] == ["list"] else parts[1:2]
            elements[-1][2] &= all(t in _PLY_INTEGERS for t in types)
    if fmt is None:
        raise MeshError(f"{path}: the header has no 'format' line")
    counts = {name: count for name, count, _ in elements}
    if counts.get("vertex", 0) > 3 * MAX_TRIANGLES:
        raise MeshError(f"{path}: {counts['vertex']} vertices, more than the limit of {3 * MAX_TRIANGLES}")
    check_triangle_count(str(path), counts.get("face", 0))
    if fmt == "ascii":
        lines, start = data[data.find(b"\n", end) + 1:].splitlines(), 0
        rows = sum(1 for line in lines if line.strip())
        if rows < sum(counts.values()):
            raise MeshError(f"{path}: the header announces {sum(counts.values())} element lines, the body has "
                            f"{rows}: cut short?")
        for name, count, integers in elements:
            if integers and re.search(rb"[^-+0-9 \t]", b" ".join(lines[start:start + count])):
                raise MeshError(f"{path}: the {name} element holds a value that is not an integer")
            start += count
    return counts.get("face", 0)


def _stl_faces(path: Path, data: bytes) -> int:
    """The triangle count of a binary STL (the header's, when the file length agrees) or an ASCII one,
    whose `solid` must close with `endsolid` (a file without it is cut short, and trimesh reads no face)."""
    if len(data) >= 84:
        count = int(np.frombuffer(data, "<u4", 1, 80)[0])
        if len(data) == 84 + 50 * count:
            return count
    if data.lstrip().lower().startswith(b"solid") and b"endsolid" not in data.lower():
        raise MeshError(f"{path}: an ASCII STL whose 'solid' is never closed by 'endsolid' (cut short?)")
    return data.count(b"endfacet")


def _off_faces(data: bytes) -> int:
    """The face count an OFF header states (0 when there is none to read: trimesh then says why)."""
    tokens = re.sub(rb"#[^\n]*", b"", data[:4096]).split()
    if len(tokens) >= 3 and tokens[0] in (b"OFF", b"COFF") and tokens[2].isdigit():
        return int(tokens[2])
    return 0
