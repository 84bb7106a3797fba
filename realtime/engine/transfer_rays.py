"""The rays of precomputed transfer (numpy + Embree, no OpenGL), shared by the two techniques that trace them:
`diffuse = "prt"` (realtime/techniques/prt/prt_transfer.py: SH transfer, its visibility and bounces) and
`diffuse = "wavelet_prt"` (realtime/techniques/wavelet_prt/wavelet_transfer.py: cube-texel visibility and the
same bounces). Techniques never import each other, so the rules both must follow to see the same geometry live
here, below them:

- the input: `TransferObject` (world-space positions, unit normals, counter-clockwise triangles, kd,
  two_sided), `transfer_objects(scene)` building them from a scene, `check_object`, which refuses what a
  transfer cannot use (shapes, NaN or Inf, indices out of range, zero normals) naming the object, and
  `check_bounces`;
- the scene as one mesh (`merge`) and its Embree intersector (`intersector`: trimesh + embreex, Embree's
  watertight test; no slow fallback, RuntimeError without embreex);
- ray origins x + eps n, eps = EPSILON_FRACTION x the diagonal of the bounding box of all objects (`epsilon`);
- visibility: any hit, front or back face, blocks a ray (`visible`);
- the hemisphere rays of a vertex (`hemisphere_hits`): R cosine-weighted directions (density cos / pi), a
  Fibonacci lattice of R points in the unit square, ((j + 1/2) / R, frac(j / phi)) (`lattice`), shifted per
  vertex by a random Cranley-Patterson rotation (Cranley & Patterson 1976; seeded: deterministic and
  unbiased; drawn once for all vertices, so chunking does not change them), mapped to the cosine-weighted
  hemisphere by r = sqrt(u1), phi = 2 pi u2 (Malley's method; `directions`) in the frame of Duff et al. 2017
  (`frames`), each traced to its first hit;
- the bounce gather of Sloan, Kautz & Snyder 2002's iterative gathering (`FrontGather`, `gather_matrix`): the
  first hit of a ray on a FRONT face (direction . geometric face normal < 0) at y gathers kd(y) (.) T(y) / R,
  T(y) interpolated barycentrically from the hit triangle's vertices; a back-face hit gathers 0. As one sparse
  matrix G (V x V), G[x, i] = sum of the barycentric weights / R of x's rays landing on triangles with vertex i,
  a bounce is T^b = G (kd (.) T^{b-1}). (Derivation: the Lambertian radiance leaving y is kd / pi E(y); with
  density cos / pi the irradiance it gives x is estimated by (1 / R) sum kd E(y_j): the pi's cancel.);
- the host-memory budget (`memory_limit`) and the progress bar (`progress_bar`);
- the digests of the two disk caches: a cache key over the settings and every object's arrays (`cache_key`)
  and the checksum of an entry's arrays and metadata (`entry_checksum`).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from rich import progress as rp
from rich.console import Console
from scipy import sparse

from scenes.storage.disk_cache import digest_arrays

#: ray origins are offset along the normal by this fraction of the scene's bounding-box diagonal
EPSILON_FRACTION = 1e-4
#: the most hemisphere rays traced at once by `gather_matrix`
MAX_GATHER_RAYS_PER_CHUNK = 1 << 19
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0  # 1 / phi


# ---------------------------------------------------------------------------------------------- input


@dataclass(frozen=True, eq=False)  # eq=False: arrays have no truth value (as scenes.geometry.meshes.Mesh)
class TransferObject:
    """One object of a transfer's input, in world space."""
    positions: np.ndarray  # (V, 3) world space
    normals: np.ndarray  # (V, 3) unit (per-vertex shading normals)
    indices: np.ndarray  # (T, 3) int, counter-clockwise seen from the front
    kd: tuple[float, float, float]  # diffuse albedo (RGB) of the object (for bounces)
    two_sided: bool = False


@dataclass(frozen=True, eq=False)
class CheckedObject:
    """A TransferObject as `check_object` accepted it."""
    positions: np.ndarray  # (V, 3) float64
    normals: np.ndarray  # (V, 3) float64, unit
    indices: np.ndarray  # (T, 3) int64
    kd: np.ndarray  # (3,) float64


def transfer_objects(scene) -> list[TransferObject]:
    """The scene's objects as a transfer's input: world-space float64 positions and normals, the mesh's
    indices, each object's kd and two_sided."""
    return [TransferObject(o.mesh.positions.astype(np.float64), o.mesh.normals.astype(np.float64), o.mesh.indices,
                           tuple(float(c) for c in o.material.kd), bool(o.material.two_sided))
            for o in scene.objects]


def check_object(what: str, obj: TransferObject) -> CheckedObject:
    """`obj` in float64 with int64 indices and its normals normalised; ValueError starting with `what` (e.g.
    "PRT object 2") for positions not (V, 3) with V > 0, normals of another shape, indices not (T, 3) integers
    or out of range, kd not 3 values, NaN or Inf in positions, normals or kd, or a normal of length < 1e-6."""
    p = np.asarray(obj.positions, dtype=np.float64)
    n = np.asarray(obj.normals, dtype=np.float64)
    idx = np.asarray(obj.indices)
    kd = np.asarray(obj.kd, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0:
        raise ValueError(f"{what}: positions must be (V, 3) with V > 0, got shape {p.shape}")
    if n.shape != p.shape:
        raise ValueError(f"{what}: normals have shape {n.shape}, positions {p.shape}")
    if idx.ndim != 2 or idx.shape[1] != 3 or (idx.size and not np.issubdtype(idx.dtype, np.integer)):
        raise ValueError(f"{what}: indices must be (T, 3) integers, got shape {idx.shape} {idx.dtype}")
    if kd.shape != (3,):
        raise ValueError(f"{what}: kd must be 3 values (RGB), got shape {kd.shape}")
    for name, a in (("positions", p), ("normals", n), ("kd", kd)):
        if not np.isfinite(a).all():
            raise ValueError(f"{what}: {name} contain NaN or Inf")
    idx = idx.astype(np.int64)
    if idx.size and (idx.min() < 0 or idx.max() >= len(p)):
        raise ValueError(f"{what}: triangle indices out of range (0..{len(p) - 1})")
    length = np.linalg.norm(n, axis=1)
    if (length < 1e-6).any():
        raise ValueError(f"{what}: {(length < 1e-6).sum()} normals have zero length")
    return CheckedObject(p, n / length[:, None], idx, kd)


def check_bounces(who: str, bounces: int, shadowed: bool) -> None:
    """ValueError starting with `who` (e.g. "PRT") for bounces < 0, or bounces without shadowed transfer (the
    bounces gather over the hemisphere rays, which only a shadowed transfer traces)."""
    if bounces < 0:
        raise ValueError(f"{who} bounces must be >= 0, got {bounces}")
    if bounces and not shadowed:
        raise ValueError(f"{who} bounces = {bounces} needs shadowed transfer (interreflection gathers over the "
                         "visibility rays)")


@dataclass(frozen=True, eq=False)
class Merged:
    """All objects as one mesh: the vertices of object i are rows offsets[i]:offsets[i + 1]."""
    positions: np.ndarray  # (V, 3) float64
    normals: np.ndarray  # (V, 3) float64, unit
    faces: np.ndarray  # (T, 3) int64, indices into the merged vertices
    offsets: np.ndarray  # (objects + 1,) first vertex of each object, then V


def merge(objs: Sequence[CheckedObject]) -> Merged:
    """The checked objects concatenated in order, each object's triangle indices shifted by its first vertex."""
    offsets = np.concatenate([[0], np.cumsum([len(o.positions) for o in objs])])
    positions = np.concatenate([o.positions for o in objs])
    normals = np.concatenate([o.normals for o in objs])
    faces = np.concatenate([o.indices + off for o, off in zip(objs, offsets[:-1], strict=True)])
    return Merged(positions, normals, faces, offsets)


def memory_limit() -> int:
    """The most host bytes a transfer may plan for: half the machine's physical memory."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2


def progress_bar(label: str, enabled: bool):
    """A rich progress bar named `label` (a context manager giving the bar), or a null context giving None
    when not enabled."""
    if not enabled:
        return contextlib.nullcontext(None)
    columns = [rp.TextColumn(f"[bold]{label}"), rp.BarColumn(), rp.MofNCompleteColumn(), rp.TimeElapsedColumn(),
               rp.TextColumn("eta"), rp.TimeRemainingColumn(), rp.TextColumn("{task.description}", markup=False)]
    # on stderr, and only on a terminal: CI logs and pipes never see the bar
    return rp.Progress(*columns, console=Console(stderr=True), disable=not sys.stderr.isatty())


def cache_key(description: dict, objects: Sequence[TransferObject]) -> str:
    """Hex SHA-256 of a transfer's settings `description` (JSON, sorted keys) followed by every object's
    positions, normals and indices (`digest_arrays`: dtype, shape and bytes of each)."""
    h = hashlib.sha256()
    h.update(json.dumps(description, sort_keys=True).encode())
    for o in objects:
        for a in (o.positions, o.normals, o.indices):
            digest_arrays(h, np.asarray(a))
    return h.hexdigest()


def entry_checksum(arrays: Sequence[np.ndarray], meta_json: str) -> str:
    """Hex SHA-256 of a cache entry's arrays (`digest_arrays`, in order) followed by its metadata JSON."""
    h = hashlib.sha256()
    for a in arrays:
        digest_arrays(h, a)
    h.update(meta_json.encode())
    return h.hexdigest()


# ---------------------------------------------------------------------------------------------- rays


def epsilon(positions: np.ndarray) -> float:
    """The ray-origin offset along the normal for the vertices (V, 3) of all objects: EPSILON_FRACTION x the
    diagonal of their bounding box (at least 1e-12 x EPSILON_FRACTION)."""
    diagonal = float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0)))
    return EPSILON_FRACTION * max(diagonal, 1e-12)


def intersector(vertices: np.ndarray, faces: np.ndarray, who: str):
    """The Embree intersector (trimesh.ray.ray_pyembree.RayMeshIntersector) of the mesh (vertices, faces),
    built with process=False (vertices and faces as given); RuntimeError naming `who` (e.g. "PRT") without
    embreex."""
    import trimesh  # deferred: heavy (about 0.3 s), only the precomputation needs it

    try:
        from trimesh.ray import ray_pyembree  # deferred: embreex is optional; refused with a reason below
    except ImportError as exc:
        raise RuntimeError(f"{who} visibility needs Embree: the embreex package is missing (pip install "
                           "embreex); there is no slow fallback") from exc
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    ray = mesh.ray
    if not isinstance(ray, ray_pyembree.RayMeshIntersector):
        raise RuntimeError(f"{who} visibility needs Embree, but trimesh gave {type(ray).__module__}."
                           f"{type(ray).__name__}: the embreex package is missing (pip install embreex)")
    return ray


def visible(ray, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(N,) bool: whether each ray (origins, directions: (N, 3)) escapes every triangle of the intersector
    `ray` (any hit, front or back face, blocks it)."""
    if len(origins) == 0:
        return np.zeros(0, dtype=bool)
    return ~np.asarray(ray.intersects_any(origins, directions), dtype=bool)


def frames(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent t and bitangent b (each (V, 3)) of unit normals n (V, 3): (t, b, n) is orthonormal and
    right-handed (t x b = n) for every unit n, the north and south poles included."""
    # Duff, Burgess, Christensen, Hery, Kensler, Liani & Villemin 2017, "Building an orthonormal basis,
    # revisited" (JCGT 6(1)), listing 3: s = sign(z) (+1 at z = 0), a = -1 / (s + z), c = x y a,
    # t = (1 + s x^2 a, s c, -s x), b = (c, s + y^2 a, -y); |s + z| >= 1, so no division by ~0 (Frisvad's
    # 1 / (1 + z) loses its precision as z -> -1).
    x, y, z = n[:, 0], n[:, 1], n[:, 2]
    s = np.where(z >= 0.0, 1.0, -1.0)
    a = -1.0 / (s + z)
    b = x * y * a
    t = np.stack([1.0 + s * x * x * a, s * b, -s * x], axis=1)
    bt = np.stack([b, s + y * y * a, -y], axis=1)
    return t, bt


def lattice(rays: int) -> np.ndarray:
    """The Fibonacci lattice of `rays` points in [0, 1)^2, ((j + 1/2) / R, frac(j / phi)) for j = 0 .. R - 1:
    (R, 2) float64."""
    # a rank-1 lattice with the golden ratio's generator: its first coordinate is stratified in R equal
    # strata, the second the most evenly spread sequence frac(j / phi) (Weyl), for any R (not only Fibonacci
    # numbers)
    j = np.arange(rays, dtype=np.float64)
    return np.stack([(j + 0.5) / rays, np.mod(j * _GOLDEN, 1.0)], axis=1)


def directions(n: np.ndarray, shifts: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Unit directions (V, R, 3) with density cos / pi about unit normals n (V, 3): the points (R, 2) of
    [0, 1)^2 (a `lattice`) shifted modulo 1 by each vertex's Cranley-Patterson rotation shifts (V, 2), mapped
    to the hemisphere of n in the frame of `frames`."""
    # Cranley & Patterson 1976: a lattice shifted by a uniform random vector modulo 1 is an unbiased estimator's
    # point set. Malley's method: (r, phi) = (sqrt(u1), 2 pi u2) is uniform in the unit disc; lifted to the
    # hemisphere, z = sqrt(1 - r^2) = sqrt(1 - u1), the disc's area element r dr dphi is cos dw, so the
    # directions have density cos / pi.
    u = np.mod(points[None, :, :] + shifts[:, None, :], 1.0)
    r = np.sqrt(u[..., 0])
    phi = 2.0 * np.pi * u[..., 1]
    lx, ly = r * np.cos(phi), r * np.sin(phi)
    lz = np.sqrt(np.maximum(1.0 - u[..., 0], 0.0))
    t, bt = frames(n)
    return lx[..., None] * t[:, None, :] + ly[..., None] * bt[:, None, :] + lz[..., None] * n[:, None, :]


@dataclass(frozen=True, eq=False)
class HemisphereHits:
    """The first hits of the hemisphere rays of vertices start:end (`hemisphere_hits`)."""
    start: int
    end: int
    directions: np.ndarray  # (end - start, R, 3) float64 unit, cosine-weighted about each vertex's normal
    origins: np.ndarray  # (end - start) R x 3: each vertex's x + eps n, repeated R times (row-major with directions)
    triangles: np.ndarray  # ((end - start) R,) index of the first triangle hit, -1 where the ray escaped


def hemisphere_hits(ray, positions: np.ndarray, normals: np.ndarray, rays: int, seed: int, eps: float,
                    chunk: int) -> Iterator[HemisphereHits]:
    """The first hits of `rays` cosine-weighted rays per vertex (module docstring) from positions + eps normals
    (both (V, 3), normals unit), `chunk` vertices at a time. The Cranley-Patterson rotations are drawn from
    numpy's default_rng(seed) for all V vertices at once, so the rays do not depend on `chunk`."""
    v_total = len(positions)
    shifts = np.random.default_rng(seed).random((v_total, 2))
    points = lattice(rays)
    for s in range(0, v_total, chunk):
        e = min(s + chunk, v_total)
        n = normals[s:e]
        d = directions(n, shifts[s:e], points)  # (c, R, 3)
        origins = np.repeat(positions[s:e] + eps * n, rays, axis=0)
        yield HemisphereHits(s, e, d, origins, ray.intersects_first(origins, d.reshape(-1, 3)))


class FrontGather:
    """The bounce gather's rows (module docstring) of the merged mesh (positions (V, 3), faces (T, 3))."""

    def __init__(self, positions: np.ndarray, faces: np.ndarray) -> None:
        self.vertices = len(positions)
        self.faces = faces
        self.p0 = positions[faces[:, 0]]
        self.face_n = np.cross(positions[faces[:, 1]] - self.p0, positions[faces[:, 2]] - self.p0)
        self.triangles = positions[faces]

    def rows(self, hits: HemisphereHits, rays: int) -> sparse.csr_matrix:
        """G's rows hits.start:hits.end, (end - start) x V CSR: each ray whose first hit is a front face adds
        its hit point's barycentric weights / rays to the hit triangle's vertices.

        The hit point is the ray / face-plane intersection in float64 (o + dist d, dist = (p0 - o) . N / d . N),
        its barycentrics by trimesh.triangles.points_to_barycentric, clamped to >= 0 and renormalised (a
        degenerate triangle's weights: 1/3 each)."""
        import trimesh  # deferred: heavy (about 0.3 s), only the precomputation needs it

        flat = np.flatnonzero(hits.triangles >= 0)
        t_hit = hits.triangles[flat]
        dirs = hits.directions.reshape(-1, 3)[flat]
        dn = np.einsum("ij,ij->i", dirs, self.face_n[t_hit])
        front = dn < 0.0
        flat, t_hit, dirs, dn = flat[front], t_hit[front], dirs[front], dn[front]
        o = hits.origins[flat]
        dist = np.einsum("ij,ij->i", self.p0[t_hit] - o, self.face_n[t_hit]) / dn
        bary = trimesh.triangles.points_to_barycentric(self.triangles[t_hit], o + dist[:, None] * dirs)
        bary = np.clip(np.nan_to_num(bary, nan=0.0), 0.0, None)
        total = bary.sum(axis=1, keepdims=True)
        bary = np.where(total > 0.0, bary / np.where(total > 0.0, total, 1.0), 1.0 / 3.0)
        rows = np.repeat(flat // rays, 3)
        shape = (hits.end - hits.start, self.vertices)
        return sparse.coo_matrix((bary.ravel() / rays, (rows, self.faces[t_hit].ravel())), shape=shape).tocsr()


def gather_matrix(ray, positions: np.ndarray, normals: np.ndarray, faces: np.ndarray, rays: int, seed: int,
                  eps: float, chunk_rays: int = MAX_GATHER_RAYS_PER_CHUNK) -> sparse.csr_matrix:
    """G (V x V CSR float64) of the bounce gather (module docstring) of all vertices of the merged mesh
    (positions, unit normals, faces) whose intersector is `ray`, at most `chunk_rays` rays traced at once."""
    gather = FrontGather(positions, faces)
    chunk = max(1, chunk_rays // rays)
    return sparse.vstack([gather.rows(h, rays) for h in hemisphere_hits(ray, positions, normals, rays, seed, eps,
                                                                          chunk)], format="csr")
