"""Rays of the wavelet transfer (numpy + Embree): the visibility of cube-texel directions and the bounce gather.

Techniques are self-contained packages (no technique imports another), so the ray rules of `diffuse = "prt"`
are restated here, the same rules with the same constants, so that the two techniques see the same geometry:

- origins x + eps n, eps = EPSILON_FRACTION x the diagonal of the bounding box of all objects;
- any hit, front or back face, blocks a visibility ray (Embree's watertight test through trimesh + embreex;
  no slow fallback: RuntimeError without embreex);
- the bounce gather (Sloan, Kautz & Snyder 2002's iterative gathering): `rays` cosine-weighted directions per
  vertex, a Fibonacci lattice ((j + 1/2) / R, frac(j / phi)) shifted per vertex by a Cranley-Patterson rotation
  drawn from `seed`, mapped by r = sqrt(u1), phi = 2 pi u2 (Malley) in the frame of Duff et al. 2017; the first
  hit on a FRONT face (direction . geometric normal < 0) at y gathers kd(y) (.) T(y) / R, T(y) interpolated
  barycentrically; as one sparse matrix G (V x V), G[x, i] = sum of barycentric weights / R of x's rays
  landing on triangles with vertex i, so a bounce is T^b = G (kd (.) T^{b-1}). (Derivation: the Lambertian
  radiance leaving y is kd/pi E(y); with density cos/pi the irradiance it gives x is estimated by
  (1/R) sum kd E(y_j): the pi's cancel.)
"""

from __future__ import annotations

import math

import numpy as np
from scipy import sparse

#: ray origins are offset along the normal by this fraction of the scene's bounding-box diagonal
EPSILON_FRACTION = 1e-4
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0  # 1 / phi


def epsilon(positions: np.ndarray) -> float:
    """The origin offset of all objects' vertices (V, 3)."""
    diagonal = float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0)))
    return EPSILON_FRACTION * max(diagonal, 1e-12)


def intersector(vertices: np.ndarray, faces: np.ndarray):
    """(trimesh.Trimesh, its Embree intersector); RuntimeError without embreex."""
    import trimesh  # deferred: heavy (about 0.3 s), only the precomputation needs it

    try:
        from trimesh.ray import ray_pyembree  # deferred: embreex is optional; refused with a reason below
    except ImportError as exc:
        raise RuntimeError("wavelet PRT visibility needs Embree: the embreex package is missing (pip install "
                           "embreex); there is no slow fallback") from exc
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    ray = mesh.ray
    if not isinstance(ray, ray_pyembree.RayMeshIntersector):
        raise RuntimeError(f"wavelet PRT visibility needs Embree, but trimesh gave {type(ray).__module__}."
                           f"{type(ray).__name__}: the embreex package is missing (pip install embreex)")
    return mesh, ray


def _frames(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent and bitangent of unit normals n (V, 3) (Duff et al. 2017, JCGT 6(1)), each (V, 3)."""
    x, y, z = n[:, 0], n[:, 1], n[:, 2]
    s = np.where(z >= 0.0, 1.0, -1.0)
    a = -1.0 / (s + z)
    b = x * y * a
    t = np.stack([1.0 + s * x * x * a, s * b, -s * x], axis=1)
    bt = np.stack([b, s + y * y * a, -y], axis=1)
    return t, bt


def _lattice(rays: int) -> np.ndarray:
    """The Fibonacci lattice of `rays` points in [0, 1)^2: (R, 2)."""
    j = np.arange(rays, dtype=np.float64)
    return np.stack([(j + 0.5) / rays, np.mod(j * _GOLDEN, 1.0)], axis=1)


def _directions(n: np.ndarray, shifts: np.ndarray, lattice: np.ndarray) -> np.ndarray:
    """Cosine-weighted directions (V, R, 3) about unit normals n (V, 3), each vertex's lattice shifted."""
    u = np.mod(lattice[None, :, :] + shifts[:, None, :], 1.0)
    r = np.sqrt(u[..., 0])
    phi = 2.0 * np.pi * u[..., 1]
    lx, ly = r * np.cos(phi), r * np.sin(phi)
    lz = np.sqrt(np.maximum(1.0 - u[..., 0], 0.0))
    t, bt = _frames(n)
    return lx[..., None] * t[:, None, :] + ly[..., None] * bt[:, None, :] + lz[..., None] * n[:, None, :]


def gather_matrix(ray, positions: np.ndarray, normals: np.ndarray, faces: np.ndarray, rays: int, seed: int,
                  eps: float, chunk_rays: int = 1 << 19) -> sparse.csr_matrix:
    """G (V x V CSR) of the bounce gather (module docstring) for all vertices."""
    import trimesh  # deferred: heavy (about 0.3 s), only the precomputation needs it

    v_total = len(positions)
    shifts = np.random.default_rng(seed).random((v_total, 2))
    lattice = _lattice(rays)
    p0 = positions[faces[:, 0]]
    face_n = np.cross(positions[faces[:, 1]] - p0, positions[faces[:, 2]] - p0)
    triangles = positions[faces]
    chunk = max(1, chunk_rays // rays)
    rows_out = []
    for s in range(0, v_total, chunk):
        e = min(s + chunk, v_total)
        n = normals[s:e]
        d = _directions(n, shifts[s:e], lattice).reshape(-1, 3)
        origins = np.repeat(positions[s:e] + eps * n, rays, axis=0)
        tri = ray.intersects_first(origins, d)
        flat = np.flatnonzero(tri >= 0)
        t_hit, dirs = tri[flat], d[flat]
        dn = np.einsum("ij,ij->i", dirs, face_n[t_hit])
        front = dn < 0.0
        flat, t_hit, dirs, dn = flat[front], t_hit[front], dirs[front], dn[front]
        o = origins[flat]
        dist = np.einsum("ij,ij->i", p0[t_hit] - o, face_n[t_hit]) / dn
        bary = trimesh.triangles.points_to_barycentric(triangles[t_hit], o + dist[:, None] * dirs)
        bary = np.clip(np.nan_to_num(bary, nan=0.0), 0.0, None)
        total = bary.sum(axis=1, keepdims=True)
        bary = np.where(total > 0.0, bary / np.where(total > 0.0, total, 1.0), 1.0 / 3.0)
        rows = np.repeat(flat // rays, 3)
        g = sparse.coo_matrix((bary.ravel() / rays, (rows, faces[t_hit].ravel())), shape=(e - s, v_total))
        rows_out.append(g.tocsr())
    return sparse.vstack(rows_out, format="csr")


def visible(ray, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(N,) bool: whether each ray escapes every object (no hit at all, front or back)."""
    if len(origins) == 0:
        return np.zeros(0, dtype=bool)
    return ~np.asarray(ray.intersects_any(origins, directions), dtype=bool)
