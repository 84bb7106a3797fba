"""Triangle meshes shared by both renderers: builtin shapes and OBJ / PLY loading.

A `Mesh` is an indexed triangle list with one unit normal per vertex (float32, so both
renderers draw bit-identical geometry), counter-clockwise winding seen from outside, and a
`convex` flag (a convex object cannot shadow or reflect onto itself, design.md section 4).
Builtin meshes are centred at the origin and fit in the unit sphere (`sphere` has radius 1).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

from .directions import normalize, rotation_xyz
from .errors import MeshError


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
    acc = np.zeros_like(p)
    for k in range(3):
        np.add.at(acc, idx[:, k], fn)
    return normalize(acc)


def is_closed(p: np.ndarray, idx: np.ndarray) -> bool:
    """True when every directed edge has exactly one opposite twin (a closed, consistently
    oriented 2-manifold). Vertices at the same position (creases, seams) count as one."""
    q = np.round(np.asarray(p, dtype=np.float64) / (1e-6 * max(1e-12, float(np.abs(p).max()))))
    _, weld = np.unique(q, axis=0, return_inverse=True)
    w = weld.reshape(-1)[idx]
    e = np.concatenate([w[:, [0, 1]], w[:, [1, 2]], w[:, [2, 0]]])
    directed = {tuple(x) for x in e.tolist()}
    if len(directed) != len(e):
        return False
    return all((b, a) in directed for a, b in directed)


def is_convex(p: np.ndarray, idx: np.ndarray, rel_tol: float = 1e-6) -> bool:
    """True when no vertex lies in front of any face's plane (then the surface bounds a convex
    set and can neither occlude nor reflect onto itself)."""
    a = p[idx[:, 0]]
    fn = normalize(np.cross(p[idx[:, 1]] - a, p[idx[:, 2]] - a))
    tol = rel_tol * max(1e-12, float(np.ptp(p, axis=0).max()))
    offset = np.einsum("fk,fk->f", fn, a)
    for start in range(0, len(idx), 256):  # chunks of (V, 256) signed distances
        dist = p @ fn[start:start + 256].T - offset[start:start + 256]
        if (dist > tol).any():
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


@lru_cache(maxsize=32)
def builtin(name: str, resolution: int | None = None) -> Mesh:
    """A builtin mesh by name (cached; treat the arrays as read-only)."""
    if name not in BUILTIN_MESHES:
        raise MeshError(f"unknown builtin mesh {name!r}; choose one of {sorted(BUILTIN_MESHES)}")
    return BUILTIN_MESHES[name](resolution or DEFAULT_RESOLUTION[name])


# --------------------------------------------------------------------------- files


def load_file(path: str | Path) -> Mesh:
    """Load a mesh from .obj or .ply (ASCII or binary little/big endian)."""
    path = Path(path)
    if not path.is_file():
        raise MeshError(f"{path}: mesh file not found")
    suffix = path.suffix.lower()
    try:
        if suffix == ".obj":
            return _load_obj(path)
        if suffix == ".ply":
            return _load_ply(path)
    except (ValueError, IndexError, UnicodeDecodeError) as exc:
        if isinstance(exc, MeshError):
            raise
        raise MeshError(f"{path}: cannot parse mesh ({exc})") from None
    raise MeshError(f"{path}: unsupported mesh format {suffix!r} (use .obj or .ply)")


def _load_obj(path: Path) -> Mesh:
    v, vn, corners, faces = [], [], {}, []
    for lineno, line in enumerate(path.read_text().splitlines(), 1):
        parts = line.split()
        if not parts or parts[0].startswith("#"):
            continue
        if parts[0] == "v":
            v.append([float(x) for x in parts[1:4]])
        elif parts[0] == "vn":
            vn.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            poly = []
            for ref in parts[1:]:
                fields = ref.split("/")
                vi = int(fields[0])
                vi = vi - 1 if vi > 0 else len(v) + vi
                ni = None
                if len(fields) >= 3 and fields[2]:
                    ni = int(fields[2])
                    ni = ni - 1 if ni > 0 else len(vn) + ni
                if not 0 <= vi < len(v) or (ni is not None and not 0 <= ni < len(vn)):
                    raise MeshError(f"{path}:{lineno}: face refers to a missing vertex or normal")
                poly.append(corners.setdefault((vi, ni), len(corners)))
            faces += [(poly[0], poly[k], poly[k + 1]) for k in range(1, len(poly) - 1)]
    if not faces:
        raise MeshError(f"{path}: no faces")
    keys = list(corners)
    positions = np.array([v[vi] for vi, _ in keys])
    has_normals = all(ni is not None for _, ni in keys)
    normals = np.array([vn[ni] for _, ni in keys]) if has_normals else None
    return make_mesh(str(path), positions, np.array(faces), normals=normals)


_PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4",
              "float": "f4", "double": "f8", "int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2",
              "int32": "i4", "uint32": "u4", "float32": "f4", "float64": "f8"}


def _load_ply(path: Path) -> Mesh:
    data = path.read_bytes()
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise MeshError(f"{path}: not a PLY file")
    header = data[:end].decode("ascii").splitlines()
    body = data[data.index(b"\n", end) + 1 :]
    fmt = next(ln.split()[1] for ln in header if ln.startswith("format"))
    elements, current = [], None
    for ln in header:
        parts = ln.split()
        if parts and parts[0] == "element":
            current = {"name": parts[1], "count": int(parts[2]), "props": []}
            elements.append(current)
        elif parts and parts[0] == "property" and current is not None:
            current["props"].append(parts[1:])
    verts, faces = None, None
    if fmt == "ascii":
        tokens = body.split()
        pos = 0
        for el in elements:
            rows = []
            for _ in range(el["count"]):
                row = []
                for prop in el["props"]:
                    if prop[0] == "list":
                        k = int(tokens[pos])
                        row.append([float(x) for x in tokens[pos + 1 : pos + 1 + k]])
                        pos += 1 + k
                    else:
                        row.append(float(tokens[pos]))
                        pos += 1
                rows.append(row)
            el["rows"] = rows
    else:
        endian = "<" if fmt == "binary_little_endian" else ">"
        pos = 0
        for el in elements:
            if all(p[0] != "list" for p in el["props"]):
                dt = np.dtype([(p[1], endian + _PLY_TYPES[p[0]]) for p in el["props"]])
                arr = np.frombuffer(body, dtype=dt, count=el["count"], offset=pos)
                pos += dt.itemsize * el["count"]
                el["rows"] = [list(r) for r in arr.tolist()]
            else:
                rows = []
                for _ in range(el["count"]):
                    row = []
                    for p in el["props"]:
                        if p[0] == "list":
                            ct, it = np.dtype(endian + _PLY_TYPES[p[1]]), np.dtype(endian + _PLY_TYPES[p[2]])
                            k = int(np.frombuffer(body, ct, 1, pos)[0])
                            pos += ct.itemsize
                            row.append(np.frombuffer(body, it, k, pos).tolist())
                            pos += it.itemsize * k
                        else:
                            t = np.dtype(endian + _PLY_TYPES[p[0]])
                            row.append(float(np.frombuffer(body, t, 1, pos)[0]))
                            pos += t.itemsize
                    rows.append(row)
                el["rows"] = rows
    for el in elements:
        names = [p[-1] for p in el["props"]]
        if el["name"] == "vertex":
            arr = np.array(el["rows"], dtype=np.float64)
            verts = arr[:, [names.index(c) for c in "xyz"]]
            normals = arr[:, [names.index(c) for c in ("nx", "ny", "nz")]] if "nx" in names else None
        elif el["name"] == "face":
            li = next(i for i, p in enumerate(el["props"]) if p[0] == "list")
            polys = [row[li] for row in el["rows"]]
            faces = [(poly[0], poly[k], poly[k + 1]) for poly in polys for k in range(1, len(poly) - 1)]
    if verts is None or not faces:
        raise MeshError(f"{path}: PLY needs vertex and face elements")
    return make_mesh(str(path), verts, np.array(faces, dtype=np.int64), normals=normals)
