"""Triangle meshes shared by both renderers: builtin shapes and OBJ / PLY loading.

A `Mesh` is an indexed triangle list with one unit normal per vertex (float32, so both
renderers draw bit-identical geometry), counter-clockwise winding seen from outside, and a
`convex` flag (a convex object cannot shadow or reflect onto itself, design.md section 4).
Builtin meshes are centred at the origin and fit in the unit sphere (`sphere` has radius 1).
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

from .directions import normalize, rotation_xyz
from .errors import MeshError

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
        """Scale, then rotate about X, Y, Z (degrees), then translate (design.md section 2)."""
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


def make_mesh(name: str, positions, indices, normals=None, convex: bool | None = None,
              closed: bool | None = None) -> Mesh:
    """Build a validated Mesh; missing or zero-length normals are computed from the faces."""
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
    smooth = smooth_normals(p, idx)
    if normals is None:
        n = smooth
    else:
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


def smooth_normals(p: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Area-weighted average of adjacent face normals per vertex (unit; zero if isolated)."""
    fn = np.cross(p[idx[:, 1]] - p[idx[:, 0]], p[idx[:, 2]] - p[idx[:, 0]])
    corners = idx.reshape(-1)
    acc = np.stack([np.bincount(corners, weights=np.repeat(fn[:, c], 3), minlength=len(p)) for c in range(3)], -1)
    return normalize(acc)


def is_closed(p: np.ndarray, idx: np.ndarray) -> bool:
    """True when every directed edge has exactly one opposite twin (a closed, consistently
    oriented 2-manifold). Vertices at the same position (creases, seams) count as one."""
    q = np.round(np.asarray(p, dtype=np.float64) / (1e-6 * max(1e-12, float(np.abs(p).max()))))
    _, weld = np.unique(q, axis=0, return_inverse=True)
    w = weld.reshape(-1)[idx].astype(np.int64)
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
    from scipy.spatial import ConvexHull, QhullError, cKDTree

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


def bowl(resolution: int = 48, outer: float = 0.85, inner: float = 0.75) -> Mesh:
    """A concave hemispherical bowl (opening up, +Y) with a wall and a flat rim, closed.

    Outer hemisphere radius `outer`, inner radius `inner`; shifted so its bounding box is
    centred at the origin. Not convex: it occludes and reflects onto itself.
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
    p = np.array(pts) + np.array([0.0, outer / 2.0, 0.0])
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


BUILTIN_MESHES = {"sphere": sphere, "torus": torus, "teapot": teapot, "bowl": bowl, "plane": plane}
DEFAULT_RESOLUTION = {"sphere": 64, "torus": 48, "teapot": 12, "bowl": 48, "plane": 1}


#: triangles of each builtin shape at a resolution (checked against MAX_TRIANGLES before building)
BUILTIN_TRIANGLES = {"sphere": lambda r: 2 * max(3, 2 * r) * (max(2, r) - 1),
                     "torus": lambda r: 2 * max(3, 2 * r) * max(3, r),
                     "teapot": lambda r: 32 * 2 * max(2, r) ** 2,
                     "bowl": lambda r: 2 * max(3, 2 * r) * (2 * max(2, r // 2) - 1) + 2 * max(3, 2 * r),
                     "plane": lambda r: 2 * max(1, r) ** 2}


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


def load_file(path: str | Path) -> Mesh:
    """Load a mesh from .obj or .ply (ASCII or binary little/big endian).

    Every problem is a MeshError naming the file and, where there is one, the line or element: no
    message carries Python's own text ("list index out of range")."""
    from .files import read_input

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".obj", ".ply"):
        raise MeshError(f"{path}: unsupported mesh format {suffix!r} (use .obj or .ply)")
    data = read_input(path, "mesh file", MAX_MESH_BYTES, MeshError)
    return _load_obj(path, data) if suffix == ".obj" else _load_ply(path, data)


def _numbers(path: Path, lineno: int, fields: list[str], what: str, count: int) -> list[float]:
    if len(fields) < count:
        raise MeshError(f"{path}:{lineno}: {what} needs {count} numbers, found {len(fields)}")
    try:
        return [float(x) for x in fields[:count]]
    except ValueError:
        raise MeshError(f"{path}:{lineno}: {what} holds something that is not a number: "
                        f"{' '.join(fields[:count])[:60]!r}") from None


def _obj_index(path: Path, lineno: int, text: str, n: int, what: str) -> int:
    """A 1-based (or negative, relative) OBJ index -> 0-based; MeshError when missing or out of range."""
    try:
        i = int(text)
    except ValueError:
        raise MeshError(f"{path}:{lineno}: face corner {text[:40]!r}: {what} index is not an integer") from None
    k = i - 1 if i > 0 else n + i
    if i == 0 or not 0 <= k < n:
        raise MeshError(f"{path}:{lineno}: face refers to a missing {what} ({i}; the file has {n} so far)")
    return k


def _load_obj(path: Path, data: bytes) -> Mesh:
    polygons = len(_OBJ_FACE.findall(data))
    check_triangle_count(str(path), polygons)  # at least one triangle per polygon: refused before parsing
    text = data.decode("latin-1")
    fast = _load_obj_fast(path, text)
    return fast if fast is not None else _load_obj_lines(path, text)


_OBJ_FACE = re.compile(rb"(?m)^[ \t]*f[ \t]")


def _load_obj_fast(path: Path, text: str) -> Mesh | None:
    """The mesh _load_obj_lines reads, with numpy doing the per-corner work (a million faces in
    seconds). None for anything unusual (a bad line, a face with normals on some corners only): the
    line-by-line reader then reads the file, or names the line that is wrong."""
    v, vn, corners, sizes, nv, nvn = [], [], [], [], [], []
    for line in text.splitlines():
        parts = line.split()
        if not parts:
            continue
        head = parts[0]
        if head == "v" or head == "vn":
            if len(parts) < 4:
                return None
            (v if head == "v" else vn).append(parts[1:4])
        elif head == "f":
            corners += parts[1:]
            sizes.append(len(parts) - 1)
            nv.append(len(v))
            nvn.append(len(vn))
    sizes_a = np.asarray(sizes, dtype=np.int64)
    if not sizes or (sizes_a < 3).any():
        return None
    try:
        pos = np.array(v, dtype=np.float64).reshape(-1, 3)
        nrm = np.array(vn, dtype=np.float64).reshape(-1, 3)
        refs = _obj_corner_fields(corners)
        if refs is None:
            return None
        vi = _obj_indices(refs[0], np.repeat(nv, sizes_a))
        ni = None if refs[1] is None else _obj_indices(refs[1], np.repeat(nvn, sizes_a))
    except ValueError:
        return None
    if vi is None or (refs[1] is not None and ni is None):
        return None
    return _obj_mesh(path, pos, nrm, vi, ni, sizes_a)


def _obj_corner_fields(corners: list[str]) -> tuple[np.ndarray, np.ndarray | None] | None:
    """(vertex index texts, normal index texts or None) of face corners that all have one form:
    `v`, `v/t`, `v//n` or `v/t/n`; None when the forms are mixed (the line reader handles those)."""
    n = len(corners)
    joined = " ".join(corners)
    slashes, doubles = joined.count("/"), joined.count("//")
    if slashes == 0:
        return np.array(corners), None
    if slashes == n and doubles == 0:  # v/t
        return np.array(joined.replace("/", " ").split()).reshape(n, 2)[:, 0], None
    if slashes == 2 * n and doubles == n:  # v//n
        tokens = np.array(joined.replace("//", " ").split()).reshape(n, 2)
        return tokens[:, 0], tokens[:, 1]
    if slashes == 2 * n and doubles == 0:  # v/t/n
        tokens = np.array(joined.replace("/", " ").split()).reshape(n, 3)
        return tokens[:, 0], tokens[:, 2]
    return None


def _obj_indices(texts: np.ndarray, available: np.ndarray) -> np.ndarray | None:
    """1-based or negative (relative) OBJ indices -> 0-based; None when one is 0 or out of range."""
    i = np.array(texts, dtype=np.int64)
    k = np.where(i > 0, i - 1, available + i)
    return k if ((i != 0) & (k >= 0) & (k < available)).all() else None


def _obj_mesh(path: Path, pos: np.ndarray, nrm: np.ndarray, vi: np.ndarray, ni: np.ndarray | None,
              sizes: np.ndarray) -> Mesh:
    """Corners (vertex, normal) numbered in order of first use, polygons split into fans, as the
    line-by-line reader does."""
    key = vi * (len(nrm) + 1) + (0 if ni is None else ni + 1)
    _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    corner = rank[inverse.reshape(-1)]
    fans = sizes - 2
    poly = np.repeat(np.arange(len(sizes)), fans)
    k = np.arange(int(fans.sum())) - np.repeat(np.cumsum(fans) - fans, fans)
    start = (np.cumsum(sizes) - sizes)[poly]
    faces = np.stack([corner[start], corner[start + k + 1], corner[start + k + 2]], axis=1)
    check_triangle_count(str(path), len(faces))
    used = first[order]
    return make_mesh(str(path), pos[vi[used]], faces, normals=None if ni is None else nrm[ni[used]])


def _load_obj_lines(path: Path, text: str) -> Mesh:
    """The reference OBJ reader, line by line, naming the line of every problem."""
    v, vn, corners, faces = [], [], {}, []
    for lineno, line in enumerate(text.splitlines(), 1):
        parts = line.split()
        if not parts or parts[0].startswith("#"):
            continue
        if parts[0] == "v":
            v.append(_numbers(path, lineno, parts[1:], "a vertex", 3))
        elif parts[0] == "vn":
            vn.append(_numbers(path, lineno, parts[1:], "a normal", 3))
        elif parts[0] == "f":
            if len(parts) < 4:
                raise MeshError(f"{path}:{lineno}: a face needs at least 3 corners, found {len(parts) - 1}")
            poly = []
            for ref in parts[1:]:
                fields = ref.split("/")
                vi = _obj_index(path, lineno, fields[0], len(v), "vertex")
                ni = _obj_index(path, lineno, fields[2], len(vn), "normal") if len(fields) >= 3 and fields[2] else None
                poly.append(corners.setdefault((vi, ni), len(corners)))
            faces += [(poly[0], poly[k], poly[k + 1]) for k in range(1, len(poly) - 1)]
    if not faces:
        raise MeshError(f"{path}: no faces")
    check_triangle_count(str(path), len(faces))
    keys = list(corners)
    positions = np.array([v[vi] for vi, _ in keys])
    has_normals = all(ni is not None for _, ni in keys)
    normals = np.array([vn[ni] for _, ni in keys]) if has_normals else None
    return make_mesh(str(path), positions, np.array(faces), normals=normals)


_PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4",
              "float": "f4", "double": "f8", "int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2",
              "int32": "i4", "uint32": "u4", "float32": "f4", "float64": "f8"}
_PLY_FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}


@dataclass
class _PlyElement:
    name: str
    count: int
    props: list[tuple[str, ...]]  # ("float", "x") or ("list", "uchar", "int", "vertex_indices")
    rows: list = field(default_factory=list)


def _ply_header(path: Path, data: bytes) -> tuple[str, list[_PlyElement], int]:
    """(format, elements, offset of the body); MeshError for anything it does not understand."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise MeshError(f"{path}: not a PLY file (no 'ply' signature or no 'end_header')")
    newline = data.find(b"\n", end)
    body = len(data) if newline < 0 else newline + 1
    fmt, elements = None, []
    for lineno, raw in enumerate(data[:end].split(b"\n"), 1):
        parts = raw.decode("latin-1").split()
        if not parts or parts[0] in ("ply", "comment", "obj_info"):
            continue
        if parts[0] == "format":
            fmt = parts[1] if len(parts) > 1 else ""
            if fmt not in _PLY_FORMATS:
                raise MeshError(f"{path}: header line {lineno}: format {fmt!r} is not one of {', '.join(_PLY_FORMATS)}")
        elif parts[0] == "element":
            if len(parts) != 3 or not parts[2].isdigit():
                raise MeshError(f"{path}: header line {lineno}: expected 'element NAME COUNT'")
            elements.append(_PlyElement(parts[1], int(parts[2]), []))
        elif parts[0] == "property":
            if not elements:
                raise MeshError(f"{path}: header line {lineno}: a property before any element")
            prop = tuple(parts[1:])
            types = prop[1:3] if prop[:1] == ("list",) else prop[:1]
            if len(prop) != (4 if prop[:1] == ("list",) else 2) or any(t not in _PLY_TYPES for t in types):
                raise MeshError(f"{path}: header line {lineno}: property {' '.join(prop)[:60]!r}: expected a "
                                f"type of {', '.join(sorted(_PLY_TYPES))} and a name")
            elements[-1].props.append(prop)
        else:
            raise MeshError(f"{path}: header line {lineno}: unknown keyword {parts[0][:40]!r}")
    if fmt is None:
        raise MeshError(f"{path}: the header has no 'format' line")
    return fmt, elements, body


def _load_ply(path: Path, data: bytes) -> Mesh:
    fmt, elements, offset = _ply_header(path, data)
    by_name = {e.name: e for e in elements}
    if "vertex" not in by_name or "face" not in by_name:
        raise MeshError(f"{path}: PLY needs vertex and face elements")
    check_triangle_count(str(path), by_name["face"].count)
    if by_name["vertex"].count > 3 * MAX_TRIANGLES:
        raise MeshError(f"{path}: {by_name['vertex'].count} vertices, more than the limit of {3 * MAX_TRIANGLES}")
    reader = _PlyAscii(path, data[offset:]) if fmt == "ascii" else _PlyBinary(path, data, offset, _PLY_FORMATS[fmt])
    for el in elements:
        reader.read(el)
    vert, face = by_name["vertex"], by_name["face"]
    names = [p[-1] for p in vert.props]
    missing = [c for c in "xyz" if c not in names]
    if missing:
        raise MeshError(f"{path}: the vertex element has no {', '.join(missing)} property")
    arr = np.array(vert.rows, dtype=np.float64).reshape(vert.count, len(names))
    verts = arr[:, [names.index(c) for c in "xyz"]]
    normals = arr[:, [names.index(c) for c in ("nx", "ny", "nz")]] if all(c in names for c in ("nx", "ny", "nz")) \
        else None
    lists = [i for i, p in enumerate(face.props) if p[0] == "list"]
    if not lists:
        raise MeshError(f"{path}: the face element has no list property (vertex_indices)")
    polys = [row[lists[0]] for row in face.rows]
    for k, poly in enumerate(polys):
        if len(poly) < 3:
            raise MeshError(f"{path}: face {k} has {len(poly)} corners; a face needs at least 3")
    faces = [(poly[0], poly[k], poly[k + 1]) for poly in polys for k in range(1, len(poly) - 1)]
    if not faces:
        raise MeshError(f"{path}: no faces")
    check_triangle_count(str(path), len(faces))
    return make_mesh(str(path), verts, np.array(faces, dtype=np.int64), normals=normals)


class _PlyAscii:
    def __init__(self, path: Path, body: bytes) -> None:
        self.path, self.tokens, self.pos = path, body.split(), 0

    def _next(self, el: _PlyElement, i: int, kind: str) -> float:
        if self.pos >= len(self.tokens):
            raise MeshError(f"{self.path}: truncated: {el.name} {i} of {el.count} is incomplete")
        tok = self.tokens[self.pos]
        self.pos += 1
        try:
            value = float(tok)
        except ValueError:
            raise MeshError(f"{self.path}: {el.name} {i}: {tok[:40].decode('latin-1')!r} is not a number") from None
        if kind != "f" and not (np.isfinite(value) and value == int(value)):
            raise MeshError(f"{self.path}: {el.name} {i}: {tok[:40].decode('latin-1')!r} is not an integer")
        return value

    def read(self, el: _PlyElement) -> None:
        for i in range(el.count):
            row = []
            for p in el.props:
                if p[0] == "list":
                    k = int(self._next(el, i, "i"))
                    if k < 0:
                        raise MeshError(f"{self.path}: {el.name} {i}: a list of {k} items")
                    kind = np.dtype(_PLY_TYPES[p[2]]).kind
                    row.append([int(self._next(el, i, kind)) for _ in range(k)])
                else:
                    row.append(self._next(el, i, np.dtype(_PLY_TYPES[p[0]]).kind))
            el.rows.append(row)


class _PlyBinary:
    def __init__(self, path: Path, data: bytes, offset: int, endian: str) -> None:
        self.path, self.data, self.pos, self.endian = path, data, offset, endian

    def _take(self, el: _PlyElement, i: int, dt: np.dtype, count: int = 1) -> np.ndarray:
        size = dt.itemsize * count
        if self.pos + size > len(self.data):
            raise MeshError(f"{self.path}: truncated: {el.name} {i} of {el.count} needs {size} more bytes, "
                            f"{len(self.data) - self.pos} left")
        out = np.frombuffer(self.data, dt, count, self.pos)
        self.pos += size
        return out

    def read(self, el: _PlyElement) -> None:
        e = self.endian
        if all(p[0] != "list" for p in el.props):  # fixed-size rows: one read
            dt = np.dtype([(f"p{j}", e + _PLY_TYPES[p[0]]) for j, p in enumerate(el.props)])
            if el.count:
                arr = self._take(el, 0, dt, el.count)
                el.rows = [list(r) for r in arr.tolist()]
            return
        for i in range(el.count):
            row = []
            for p in el.props:
                if p[0] == "list":
                    k = int(self._take(el, i, np.dtype(e + _PLY_TYPES[p[1]]))[0])
                    if k < 0:
                        raise MeshError(f"{self.path}: {el.name} {i}: a list of {k} items")
                    row.append(self._take(el, i, np.dtype(e + _PLY_TYPES[p[2]]), k).tolist())
                else:
                    row.append(float(self._take(el, i, np.dtype(e + _PLY_TYPES[p[0]]))[0]))
            el.rows.append(row)
