"""Precomputed radiance transfer for diffuse surfaces: the pure numpy + Embree half (no OpenGL)
(docs/contract.md section 9, `diffuse = "prt"`, `occlusion = "prt"`, `interreflection = "prt"`).

Sloan, Kautz & Snyder 2002, "Precomputed radiance transfer for real-time rendering in dynamic,
low-frequency lighting environments" (SIGGRAPH 2002), section 5 (diffuse transfer): per vertex a
transfer vector T so that, with L the environment's SH coefficients (`scenes.environment.shbasis.sh_basis`
convention, as `realtime.engine.sh.project_equirect` computes them), the irradiance of channel c is

    E_c(v) = sum_k L_{k,c} T_{v,k,c}.

T is irradiance transfer (no albedo of the receiver in it: the shader multiplies by its own kd / pi).

Unshadowed (cosine only), exact, no Monte Carlo: T_k(x) = A_l Y_k(n(x)), with A_l the clamped-cosine
band factors of Ramamoorthi & Hanrahan 2001 (eq. 8-9, `COSINE_BAND_FACTORS`), the same for the three
channels. So PRT without shadows is SH irradiance (R&H 2001) to float precision.

Shadowed, with the unshadowed transfer as a control variate (only the occluded part is estimated):

    T_k(x) = A_l Y_k(n) - (pi / R) sum_j Y_k(w_j) (1 - V_j)

where w_j are R directions on the hemisphere about n with density cos / pi (so that
int Y_k cos (1 - V) dw = E[pi Y_k (1 - V)]), and V_j = 1 when the ray from x + eps n escapes every
object (any hit, front or back face, blocks it). Directions, eps and the any-hit rule are the shared
rules of realtime/engine/transfer_rays.py (`hemisphere_hits`): a Fibonacci lattice of R points in the unit
square shifted per vertex by a Cranley-Patterson rotation seeded by `seed` (deterministic, and unbiased),
mapped to the cosine-weighted hemisphere by Malley's method in the frame of Duff et al. 2017; eps =
EPSILON_FRACTION x the diagonal of the bounding box of all objects. A vertex none of whose rays hit gets
exactly the unshadowed transfer (subtracting nothing): a convex object with outward normals is bit for bit
its unshadowed transfer, since the tangent plane of n supports it.

Interreflected (bounces >= 1, needs shadowed): Sloan's iterative gathering over the same rays:

    T^0 = the shadowed transfer,
    T^b(x) = (1 / R) sum_{j: ray j hits a front face at y_j} kd(y_j) (.) T^{b-1}(y_j),
    T = sum_{b=0..bounces} T^b.

Derivation: the Lambertian radiance leaving y is kd(y) / pi E(y); the irradiance it gives x is
int kd/pi E(y) cos dw, estimated with density cos / pi as (1 / R) sum kd E(y_j) (the pi's cancel).
T^{b-1}(y) is interpolated barycentrically from the hit triangle's vertices; kd(y) is the hit
object's albedo per channel. A ray that hits a back face (direction . geometric face normal >= 0,
winding counter-clockwise seen from the front) gathers 0. For a one-sided object that is right (its
back is black in both renderers). For a two_sided object it is a KNOWN LIMITATION: the light leaving
its back would need the transfer for the flipped normal, which is not computed; so `two_sided` only
enters the cache key. The hits (object, triangle, barycentrics) are found once, stored as one sparse
gather matrix G (V x V, G[x, i] = sum of barycentric weights / R of the rays from x landing on
triangles with vertex i), and reused for every bounce: T^b = G (kd (.) T^{b-1}).

Rays: one mesh of all objects and its Embree intersector (`transfer_rays.intersector`: no silent slow
fallback, RuntimeError without embreex), first hits via `intersects_first` (Embree's watertight test), the
gather's rows by `transfer_rays.FrontGather` (the hit point for the barycentrics is the ray / face-plane
intersection in float64, clamped to the triangle), over the same rays as the visibility. Vertices go in
chunks of at most MAX_RAYS_PER_CHUNK rays and at most MAX_SH_VALUES_PER_CHUNK basis values (rays x
coefficients; bounded memory for the SH evaluation of the occluded directions at orders up to 8: the same
chunks as by rays alone up to order 4).

Memory guard (`transfer_bytes`, `check_memory`): the host arrays the transfer needs grow with vertices x
(order + 1)^2 (81 coefficients at order 8, 3.24 x order 4's); a configuration whose estimate exceeds
`memory_limit()` (half the machine's physical memory) is refused before anything is traced, with the bytes
it needs.

Cache (`cached_transfer`): `scenes.storage.disk_cache.cache_dir() / "prt" / "<key>.npz"`, key = SHA-256 of
every object's positions / normals / indices (dtype, shape, bytes), kd, two_sided, order, rays,
bounces, shadowed, seed and TRANSFER_VERSION. Atomic writes (temporary file + os.replace), a SHA-256 of
the arrays in each entry checked on read, and its content for meaning (`entry_problem`: the version,
vertex and ray counts of this transfer, a finite time >= 0; arrays of the right shape, float32 and
finite); a corrupt or meaningless entry is recomputed with a CacheWarning, an
unwritable folder is a CacheWarning and the transfer is returned uncached.
"""

from __future__ import annotations

import json
import time
import warnings
from collections.abc import Sequence

import numpy as np
from scipy import sparse

from realtime.engine.transfer_rays import (
    CheckedObject,
    FrontGather,
    TransferObject,
    cache_key,
    check_bounces,
    check_object,
    epsilon,
    hemisphere_hits,
    intersector,
    memory_limit,
    merge,
    progress_bar,
)
from realtime.engine.transfer_rays import entry_checksum as _entry_checksum  # tests re-sign entries by this name
from scenes.environment.shbasis import COSINE_BAND_FACTORS, band_of, count, sh_basis
from scenes.storage.disk_cache import CacheWarning, cache_dir, write_npz

#: bump when the transfer computed for the same inputs changes (invalidates the cache)
TRANSFER_VERSION = 1
#: the most rays traced (and SH-evaluated) at once
MAX_RAYS_PER_CHUNK = 1 << 19
#: the most basis values (rays x coefficients) evaluated at once: order 4's 25 per ray at full chunks
MAX_SH_VALUES_PER_CHUNK = MAX_RAYS_PER_CHUNK * 25
#: supported SH orders (COSINE_BAND_FACTORS has bands 0..8; the GLSL evaluation starts at order 2)
MIN_ORDER, MAX_ORDER = 2, len(COSINE_BAND_FACTORS) - 1


def _check_settings(order: int, rays: int, bounces: int, shadowed: bool) -> None:
    if not MIN_ORDER <= order <= MAX_ORDER:
        raise ValueError(f"PRT order must be {MIN_ORDER}..{MAX_ORDER} (the clamped-cosine factors go to band "
                         f"{MAX_ORDER}), got {order}")
    if shadowed and rays < 1:
        raise ValueError(f"PRT rays must be >= 1, got {rays}")
    check_bounces("PRT", bounces, shadowed)


def _chunk_vertices(order: int, rays: int) -> int:
    """Vertices per chunk: at most MAX_RAYS_PER_CHUNK rays and MAX_SH_VALUES_PER_CHUNK basis values."""
    return max(1, min(MAX_RAYS_PER_CHUNK // rays, MAX_SH_VALUES_PER_CHUNK // (rays * count(order))))


def transfer_bytes(vertices: int, order: int, rays: int, bounces: int, shadowed: bool) -> int:
    """Estimated peak host bytes of `transfer`: the float64 unshadowed transfer (V, K), the float64 total
    (V, K, 3) and, with bounces, the bounce term and the gathered product (two more); the float32 result
    (V, K, 3); when shadowed, a chunk's directions and ray origins (3 float64 each per ray, plus the hit
    mask and triangle ids) and its basis values (K float64 per ray, twice: values and the reduction)."""
    k = count(order)
    host = vertices * k * 8 + vertices * k * 3 * 8 * (3 if bounces else 1) + vertices * k * 3 * 4
    if shadowed:
        n_rays = min(vertices, _chunk_vertices(order, rays)) * rays
        host += n_rays * (3 * 8 * 2 + 1 + 8) + n_rays * k * 8 * 2
    return int(host)


def check_memory(vertices: int, order: int, rays: int, bounces: int, shadowed: bool) -> None:
    """MemoryError, saying what is needed, when `transfer_bytes` exceeds `memory_limit()`."""
    need, have = transfer_bytes(vertices, order, rays, bounces, shadowed), memory_limit()
    if need > have:
        raise MemoryError(f"PRT of {vertices} vertices at order {order} ({count(order)} coefficients), {rays} rays, "
                          f"{bounces} bounces needs about {need / 2**30:.2f} GiB of host memory, above the "
                          f"{have / 2**30:.2f} GiB allowed (half the physical memory): lower "
                          "realtime.prt.order or the mesh resolution")


def _unshadowed(normals: np.ndarray, order: int) -> np.ndarray:
    """A_l Y_k(n): (V, K) float64."""
    return sh_basis(normals, order) * COSINE_BAND_FACTORS[band_of(order)]


def _trace(objs: list[CheckedObject], order: int, rays: int, bounces: int, seed: int, progress: bool,
           base: np.ndarray):
    """Shadowed transfer (V, K) float64 of all vertices, and the gather matrix (V x V CSR) when bounces > 0."""
    scene = merge(objs)
    v_total = len(scene.positions)
    shadowed = base.copy()
    gather_rows = []
    chunk = _chunk_vertices(order, rays)
    starts = range(0, v_total, chunk)
    if len(scene.faces) == 0:  # nothing to hit: every ray escapes
        return shadowed, (sparse.csr_matrix((v_total, v_total)) if bounces else None)
    ray = intersector(scene.positions, scene.faces, "PRT")
    gather = FrontGather(scene.positions, scene.faces) if bounces else None
    with progress_bar("prt", progress) as bar:
        task = bar.add_task(f"{v_total} vertices x {rays} rays", total=len(starts)) if bar is not None else None
        for hits in hemisphere_hits(ray, scene.positions, scene.normals, rays, seed, epsilon(scene.positions), chunk):
            s, e = hits.start, hits.end
            hit = (hits.triangles >= 0).reshape(e - s, rays)
            per_vertex = hit.sum(axis=1)
            some = per_vertex > 0
            if some.any():
                y = sh_basis(hits.directions[hit], order)  # rows in vertex order (row-major mask)
                first = np.concatenate([[0], np.cumsum(per_vertex)[:-1]])[some]
                shadowed[s:e][some] -= (np.pi / rays) * np.add.reduceat(y, first, axis=0)
            if gather is not None:
                gather_rows.append(gather.rows(hits, rays))
            if bar is not None:
                bar.advance(task)
    return shadowed, (sparse.vstack(gather_rows, format="csr") if bounces else None)


def _transfer(objects: Sequence[TransferObject], order: int, rays: int, bounces: int, shadowed: bool,
              seed: int, progress: bool) -> tuple[list[np.ndarray], int]:
    """transfer() and the number of rays it traced."""
    order, rays, bounces, seed = int(order), int(rays), int(bounces), int(seed)
    _check_settings(order, rays, bounces, shadowed)
    if len(objects) == 0:
        raise ValueError("PRT needs at least one object")
    objs = [check_object(f"PRT object {i}", o) for i, o in enumerate(objects)]
    check_memory(sum(len(o.positions) for o in objs), order, rays, bounces, shadowed)
    base = np.concatenate([_unshadowed(o.normals, order) for o in objs])  # (V, K)
    traced = 0
    if not shadowed:
        total = np.repeat(base[:, :, None], 3, axis=2)
    else:
        t0, gather = _trace(objs, order, rays, bounces, seed, progress, base)
        traced = len(base) * rays
        total = np.repeat(t0[:, :, None], 3, axis=2)
        if bounces:
            kd = np.concatenate([np.broadcast_to(o.kd, (len(o.positions), 3)) for o in objs])
            k = total.shape[1]
            tb = total.copy()
            for _ in range(bounces):
                tb = (gather @ (kd[:, None, :] * tb).reshape(len(tb), 3 * k)).reshape(len(tb), k, 3)
                total += tb
    out, start = [], 0
    for i, o in enumerate(objs):
        t = np.ascontiguousarray(total[start:start + len(o.positions)], dtype=np.float32)
        start += len(o.positions)
        if not np.isfinite(t).all():
            raise FloatingPointError(f"PRT object {i}: the transfer has non-finite values (a bug)")
        out.append(t)
    return out, traced


def transfer(objects: Sequence[TransferObject], order: int, rays: int, bounces: int, shadowed: bool,
             seed: int = 0, progress: bool = False) -> list[np.ndarray]:
    """Per object, (V_i, (order+1)**2, 3) float32 diffuse transfer vectors T so that the irradiance at
    vertex v for channel c is E_c(v) = sum_k L_{k,c} T_{v,k,c}, with L the environment's SH coefficients
    (scenes/shbasis.sh_basis convention, the same as realtime/sh.project_equirect).

    shadowed=False: A_l Y_k(n), exact (rays and seed unused; bounces must be 0). shadowed=True:
    `rays` cosine-weighted visibility rays per vertex, then `bounces` gathering bounces (module
    docstring). Deterministic for a seed. ValueError for order outside 2..8, bounces without shadows, or
    bad inputs (naming the object); MemoryError when `check_memory` refuses; RuntimeError when shadowed
    and embreex is missing. progress=True: a
    rich progress bar over vertex chunks on stderr.
    """
    return _transfer(objects, order, rays, bounces, shadowed, seed, progress)[0]


# ---------------------------------------------------------------------------------------------- cache


def transfer_key(objects: Sequence[TransferObject], order: int, rays: int, bounces: int, shadowed: bool,
                 seed: int = 0) -> str:
    """Hex SHA-256 over everything that changes the transfer (module docstring)."""
    desc = {"kind": "prt", "version": TRANSFER_VERSION, "order": int(order), "rays": int(rays),
            "bounces": int(bounces), "shadowed": bool(shadowed), "seed": int(seed),
            "objects": [{"kd": [float(c) for c in o.kd], "two_sided": bool(o.two_sided)} for o in objects]}
    return cache_key(desc, objects)


def entry_problem(meta: object, vertices: int, rays_traced: int) -> str | None:
    """What is wrong with a cache entry's metadata (its checksum only proves it was written whole): it
    must be the record `cached_transfer` writes for this transfer: TRANSFER_VERSION, the transfer's
    vertex count, the rays it traces (`rays_traced`: vertices x rays when shadowed, else 0) and a finite
    compute time >= 0 in seconds. The arrays are checked beside it (shape, float32, finite)."""
    if not isinstance(meta, dict):
        return "its metadata is not a JSON object"
    version = meta.get("version")
    if isinstance(version, bool) or version != TRANSFER_VERSION:
        return f"version = {version!r}: this iblcheck reads version {TRANSFER_VERSION}"
    for name, want in (("vertices", vertices), ("rays_traced", rays_traced)):
        value = meta.get(name)
        if isinstance(value, bool) or not isinstance(value, int) or value != want:
            return f"{name} = {value!r}: this transfer has {want}"
    sec = meta.get("seconds")
    if isinstance(sec, bool) or not isinstance(sec, (int, float)) or not np.isfinite(sec) or sec < 0:
        return f"seconds = {sec!r}: a finite time >= 0 is required"
    return None


def _load(path, shapes: list[tuple[int, ...]], vertices: int, rays_traced: int) -> tuple[list[np.ndarray], dict] | None:
    """The arrays and metadata of a valid entry; None when missing. A corrupt entry, or one whose
    content has no meaning for this transfer (`entry_problem`), warns and returns None (recomputed)."""
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            meta_json, stored = str(z["meta"]), str(z["checksum"])
            arrays = [z[f"t{i}"] for i in range(len(shapes))]
        if _entry_checksum(arrays, meta_json) != stored:
            raise ValueError("checksum mismatch")
        for a, shape in zip(arrays, shapes, strict=True):
            if a.shape != shape or a.dtype != np.float32 or not np.isfinite(a).all():
                raise ValueError(f"an array of shape {a.shape} {a.dtype} where {shape} float32 was expected")
        meta = json.loads(meta_json)
        problem = entry_problem(meta, vertices, rays_traced)
        if problem:
            raise ValueError(problem)
        return arrays, meta
    except Exception as exc:  # any unreadable entry (truncated zip, bad checksum, ...) is recomputed
        warnings.warn(f"PRT cache entry {path} is corrupt ({exc}); recomputing it", CacheWarning, stacklevel=3)
        return None


def _store(folder, key: str, arrays: list[np.ndarray], meta: dict) -> bool:
    meta_json = json.dumps(meta, sort_keys=True)
    try:
        write_npz(folder, key, meta=np.array(meta_json), checksum=np.array(_entry_checksum(arrays, meta_json)),
                  **{f"t{i}": a for i, a in enumerate(arrays)})
        return True
    except OSError as exc:
        warnings.warn(f"PRT cache {folder} cannot be written ({exc.strerror or exc}); the transfer is returned "
                      "but not cached", CacheWarning, stacklevel=3)
        return False


def cached_transfer(objects: Sequence[TransferObject], order: int, rays: int, bounces: int, shadowed: bool,
                    seed: int = 0, progress: bool = False) -> tuple[list[np.ndarray], dict]:
    """transfer(), cached on disk under scenes.storage.disk_cache.cache_dir() / "prt" / f"{key}.npz"
    (atomic write:
    temp file + os.replace; a corrupt/unreadable entry is recomputed with a warning; an unwritable cache dir is a
    warning, not a failure), keyed by SHA-256 of every object's positions/normals/indices bytes, kd, two_sided,
    order, rays, bounces, shadowed, seed and a TRANSFER_VERSION constant. Returns (transfers, info) where info has
    {"key", "cached": bool, "seconds": compute seconds (0 if cached), "rays_traced": int, "vertices": int,
    "compute_seconds": what computing it took, also when read from the cache (E8 reports it)}.

    rays_traced is the number of rays the transfer took (vertices x rays when shadowed, else 0), also when it
    came from the cache (then `cached` is True and `seconds` 0: none were traced now).
    """
    _check_settings(int(order), int(rays), int(bounces), shadowed)
    objs = [check_object(f"PRT object {i}", o) for i, o in enumerate(objects)]  # validate before hashing
    key = transfer_key(objects, order, rays, bounces, shadowed, seed)
    folder = cache_dir() / "prt"
    vertices = sum(len(o.positions) for o in objs)
    check_memory(vertices, int(order), int(rays), int(bounces), shadowed)  # before any cache read or trace
    shapes = [(len(o.positions), count(int(order)), 3) for o in objs]
    entry = _load(folder / f"{key}.npz", shapes, vertices, vertices * int(rays) if shadowed else 0)
    if entry is not None:
        arrays, meta = entry
        return arrays, {"key": key, "cached": True, "seconds": 0.0, "rays_traced": meta["rays_traced"],
                        "vertices": vertices, "compute_seconds": float(meta["seconds"])}
    t0 = time.perf_counter()
    arrays, traced = _transfer(objects, order, rays, bounces, shadowed, seed, progress)
    seconds = time.perf_counter() - t0
    _store(folder, key, arrays, {"rays_traced": traced, "vertices": vertices, "seconds": seconds,
                                 "version": TRANSFER_VERSION})
    return arrays, {"key": key, "cached": False, "seconds": seconds, "rays_traced": traced, "vertices": vertices,
                    "compute_seconds": seconds}
