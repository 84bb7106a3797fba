"""The wavelet transfer of every vertex: the pure numpy + Embree half of `diffuse = "wavelet_prt"` (no OpenGL).

Ng, Ramamoorthi & Hanrahan 2003, "All-frequency shadows using non-linear wavelet lighting approximation"
(SIGGRAPH 2003), section 4 (the transport matrix of a diffuse receiver sampled at vertices). With the lighting
a cube map of `cube_size` texels per face side, texel t of centre direction w_t and exact solid angle dOmega_t
(scenes.environment.cubemap.texel_directions / texel_solid_angles), the irradiance at vertex v is the sum

    E(v) = sum_t L_t T_v[t],    T_v[t] = V(x_v, w_t) max(0, n_v . w_t) dOmega_t

(a midpoint quadrature of int L V cos dw over the cube's texels). V is one Embree ray per texel with
n_v . w_t > 0, from x_v + eps n_v (realtime/engine/transfer_rays.py: the eps and any-hit rule PRT's rays
follow too); unshadowed (occlusion off) V = 1. T is irradiance transfer: the shader multiplies by the
receiver's kd / pi, as PRT's.

Bounces (interreflection, needs shadows): T = sum_{b=0..bounces} T^b, T^0 as above and
T^b = G (kd (.) T^{b-1}) with G the gather matrix of the hemisphere rays (transfer_rays.gather_matrix, PRT's
gather), so T has one row per colour channel when bounces > 0 (kd per channel), one shared row otherwise.

Each face of T_v is Haar-transformed (haar.py: orthonormal, non-standard), so E = sum_j l_j w_v[j] with l the
lighting's Haar coefficients and w_v = W T_v (W orthogonal: the dot product is unchanged).

Storage rule (sparsification, Ng et al. section 4.2): coefficient j of vertex v is stored when
m_j = max_c |w_v[j, c]| is non-zero and m_j >= threshold x max_j m_j (relative to the vertex's largest
coefficient; threshold 0 keeps every non-zero coefficient). A vertex's entries are (index, value) pairs sorted
by index: one uint32 index and C float32 values (C = 1 without bounces, 3 with), 4 + 4 C bytes per entry, plus
one uint32 offset per vertex (CSR layout: offsets (V + 1), indices (nnz), values (nnz, C)).

Memory guard (`transfer_bytes`, `check_memory`): the working set of a chunk of vertices (dense texel rows in
float64, their rays), with bounces the dense (V, N, 3) float32 transfers (three: T^0, the bounce term and
the sum), and the worst-case output (every coefficient stored); a configuration above `memory_limit()`
(half the physical memory) is refused before anything is traced, with the bytes it needs.

Cache (`cached_transfer`): `cache_dir() / "wavelet_prt" / "<key>.npz"`, key = SHA-256 of every object's
positions / normals / indices (dtype, shape, bytes), cube_size, threshold, bounces, shadowed and TRANSFER_VERSION,
and with bounces > 0 (the only part they enter) each object's kd and the gather's rays and seed; atomic writes
(scenes.storage.disk_cache.write_npz), a SHA-256 of the arrays in each entry checked on read, and the arrays
checked for meaning (CSR shapes, sorted indices in range, finite values); a corrupt entry is recomputed with a
CacheWarning, an unwritable folder warns.
"""

from __future__ import annotations

import json
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from realtime.engine import transfer_rays
from realtime.engine.transfer_rays import TransferObject, memory_limit
from realtime.techniques.wavelet_prt import haar
from scenes.environment import cubemap
from scenes.storage.disk_cache import CacheWarning, cache_dir, write_npz

#: bump when the transfer computed for the same inputs changes (invalidates the cache)
TRANSFER_VERSION = 1
#: the most texel rays (vertices x texels) handled at once
MAX_TEXELS_PER_CHUNK = 1 << 21


@dataclass(frozen=True, eq=False)
class SparseTransfer:
    """One object's sparse Haar transfer (CSR): vertex v's entries are offsets[v]:offsets[v + 1]."""
    offsets: np.ndarray  # (V + 1,) int64
    indices: np.ndarray  # (nnz,) uint32, flat coefficient index (face, row, column), sorted per vertex
    values: np.ndarray  # (nnz, C) float32, C = 1 (one transfer for all channels) or 3

    @property
    def channels(self) -> int:
        return int(self.values.shape[1])

    @property
    def nbytes(self) -> int:
        """Bytes on the GPU: uint32 offsets, uint32 indices, float32 values."""
        return 4 * len(self.offsets) + 4 * len(self.indices) + self.values.nbytes

    def dense(self, coefficients: int) -> np.ndarray:
        """(V, coefficients, C) float64 (for tests)."""
        v = len(self.offsets) - 1
        out = np.zeros((v, coefficients, self.channels))
        rows = np.repeat(np.arange(v), np.diff(self.offsets))
        out[rows, self.indices.astype(np.int64)] = self.values
        return out


def irradiance(transfer: SparseTransfer, lighting: np.ndarray) -> np.ndarray:
    """E (V, 3) float64 = sum over a vertex's entries of value x lighting[index] (lighting: (N, 3) Haar
    coefficients, the unselected ones zero): what the GPU's per-vertex pass computes."""
    light = np.asarray(lighting, dtype=np.float64)[transfer.indices.astype(np.int64)]  # (nnz, 3)
    prod = transfer.values.astype(np.float64) * light  # (nnz, 3): C = 1 broadcasts
    v = len(transfer.offsets) - 1
    rows = np.repeat(np.arange(v), np.diff(transfer.offsets))
    out = np.zeros((v, 3))
    np.add.at(out, rows, prod)
    return out


def lighting_coefficients(faces: np.ndarray) -> np.ndarray:
    """Haar coefficients (6 s s, 3) of RGB cube faces (6, s, s, >= 3), flat in C order per channel."""
    f = np.asarray(faces, dtype=np.float64)[..., :3]
    return np.moveaxis(haar.forward(np.moveaxis(f, -1, 1)), 1, -1).reshape(-1, 3)


def selected_lighting(coeffs: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(dense (N, 3) with all but the K kept coefficients zeroed, the kept flat indices) (haar.select)."""
    size = int(round(np.sqrt(len(coeffs) / 6)))
    kept = haar.select(haar.selection_keys(coeffs.reshape(6, size, size, 3)), k)
    out = np.zeros_like(coeffs, dtype=np.float64)
    out[kept] = coeffs[kept]
    return out, kept


# ---------------------------------------------------------------------------------------------- transfer


def _check_settings(cube_size: int, threshold: float, rays_: int, bounces: int, shadowed: bool) -> None:
    if cube_size < 1 or cube_size & (cube_size - 1):
        raise ValueError(f"wavelet PRT cube_size must be a power of two, got {cube_size}")
    if not (np.isfinite(threshold) and threshold >= 0):
        raise ValueError(f"wavelet PRT threshold must be a finite number >= 0, got {threshold}")
    transfer_rays.check_bounces("wavelet PRT", bounces, shadowed)
    if bounces and rays_ < 1:
        raise ValueError(f"wavelet PRT rays must be >= 1, got {rays_}")


def _chunk(cube_size: int) -> int:
    return max(1, MAX_TEXELS_PER_CHUNK // (6 * cube_size * cube_size))


def transfer_bytes(vertices: int, cube_size: int, bounces: int) -> int:
    """Estimated peak host bytes (module docstring): a chunk's dense rows (cosines, transfer, Haar
    coefficients and their work copies: 6 float64 per texel) and its rays (origins and directions, 6 float64,
    and a flag), the dense bounce arrays (3 x V N 3 float32) and the worst-case output (every coefficient:
    uint32 index + C float32 values, float64 while gathered: 4 + 8 C)."""
    n = 6 * cube_size * cube_size
    c = 3 if bounces else 1
    rows = min(vertices, _chunk(cube_size)) * n
    host = rows * (6 * 8) + rows * (6 * 8 + 1) * c
    if bounces:
        host += 3 * vertices * n * 3 * 4
    host += vertices * n * (4 + 8 * c)
    return int(host)


def check_memory(vertices: int, cube_size: int, bounces: int) -> None:
    """MemoryError, saying the bytes needed, when `transfer_bytes` exceeds `memory_limit()`."""
    need, have = transfer_bytes(vertices, cube_size, bounces), memory_limit()
    if need > have:
        raise MemoryError(f"wavelet PRT of {vertices} vertices at cube_size {cube_size} ({6 * cube_size ** 2} "
                          f"texels), {bounces} bounces needs about {need} bytes ({need / 2**30:.2f} GiB) of host "
                          f"memory, above the {have} bytes ({have / 2**30:.2f} GiB) allowed (half the physical "
                          "memory): lower realtime.wavelet_prt.cube_size or the mesh resolution")


def _sparsify(w: np.ndarray, threshold: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(counts (c,), indices (nnz,), values (nnz, C)) of Haar rows w (c, N, C) by the storage rule."""
    m = np.abs(w).max(axis=2)  # (c, N)
    keep = (m > 0.0) & (m >= threshold * m.max(axis=1, keepdims=True))
    rows, cols = np.nonzero(keep)  # row-major: per vertex, indices ascending
    return keep.sum(axis=1), cols.astype(np.uint32), w[rows, cols].astype(np.float32)


def _texel_rows(ray, p: np.ndarray, n: np.ndarray, dirs: np.ndarray, omega: np.ndarray, eps: float,
                shadowed: bool) -> tuple[np.ndarray, int]:
    """T (c, N) float64 of vertices p, n (c, 3) and the rays traced."""
    cos = n @ dirs.T  # (c, N)
    front = cos > 0.0
    t = np.where(front, cos * omega[None, :], 0.0)
    if not shadowed or ray is None:
        return t, 0
    vi, ti = np.nonzero(front)
    seen = transfer_rays.visible(ray, p[vi] + eps * n[vi], dirs[ti])
    t[vi[~seen], ti[~seen]] = 0.0
    return t, len(vi)


def _haar_rows(t: np.ndarray, cube_size: int) -> np.ndarray:
    """(c, N, C) Haar coefficients of texel rows (c, N, C)."""
    c, _, ch = t.shape
    faces = np.moveaxis(t.reshape(c, 6, cube_size, cube_size, ch), -1, 1)  # (c, C, 6, s, s)
    return np.moveaxis(haar.forward(faces), 1, -1).reshape(c, -1, ch)


def _transfer(objects: Sequence[TransferObject], cube_size: int, threshold: float, rays_: int, bounces: int,
              shadowed: bool, seed: int, progress: bool) -> tuple[list[SparseTransfer], int]:
    cube_size, rays_, bounces, seed, threshold = int(cube_size), int(rays_), int(bounces), int(seed), float(threshold)
    _check_settings(cube_size, threshold, rays_, bounces, shadowed)
    if len(objects) == 0:
        raise ValueError("wavelet PRT needs at least one object")
    objs = [transfer_rays.check_object(f"wavelet PRT object {i}", o) for i, o in enumerate(objects)]
    scene = transfer_rays.merge(objs)
    positions, normals, faces, offsets = scene.positions, scene.normals, scene.faces, scene.offsets
    v_total = len(positions)
    check_memory(v_total, cube_size, bounces)
    dirs = cubemap.texel_directions(cube_size).reshape(-1, 3)
    omega = np.tile(cubemap.texel_solid_angles(cube_size).reshape(-1), 6)
    ray = None
    eps = transfer_rays.epsilon(positions)
    if shadowed and len(faces):
        ray = transfer_rays.intersector(positions, faces, "wavelet PRT")
    chunk = _chunk(cube_size)
    starts = range(0, v_total, chunk)
    counts, idx_parts, val_parts = [], [], []
    traced = 0
    dense = np.zeros((v_total, len(dirs)), dtype=np.float32) if bounces else None
    with transfer_rays.progress_bar("wavelet prt", progress) as bar:
        task = bar.add_task(f"{v_total} vertices x {len(dirs)} texels", total=len(starts)) if bar is not None else None
        for s in starts:
            e = min(s + chunk, v_total)
            t, n_rays = _texel_rows(ray, positions[s:e], normals[s:e], dirs, omega, eps, shadowed)
            traced += n_rays
            if bounces:
                dense[s:e] = t
            else:
                cnt, idx, val = _sparsify(_haar_rows(t[..., None], cube_size), threshold)
                counts.append(cnt)
                idx_parts.append(idx)
                val_parts.append(val)
            if bar is not None:
                bar.advance(task)
    if bounces:
        kd = np.concatenate([np.broadcast_to(o.kd, (len(o.positions), 3)) for o in objs]).astype(np.float32)
        gather = transfer_rays.gather_matrix(ray, positions, normals, faces, rays_, seed, eps).astype(np.float32) \
            if ray is not None else None
        total = np.repeat(dense[:, :, None], 3, axis=2)
        tb = total.copy()
        del dense
        for _ in range(bounces):
            if gather is None:
                break
            tb = (gather @ (kd[:, None, :] * tb).reshape(v_total, -1)).reshape(tb.shape)
            total += tb
        del tb
        for s in starts:
            e = min(s + chunk, v_total)
            cnt, idx, val = _sparsify(_haar_rows(total[s:e].astype(np.float64), cube_size), threshold)
            counts.append(cnt)
            idx_parts.append(idx)
            val_parts.append(val)
    counts = np.concatenate(counts)
    all_idx = np.concatenate(idx_parts)
    all_val = np.concatenate(val_parts)
    if not np.isfinite(all_val).all():
        raise FloatingPointError("wavelet PRT: the transfer has non-finite values (a bug)")
    out = []
    entry = np.concatenate([[0], np.cumsum(counts)])
    for i in range(len(objs)):
        lo, hi = entry[offsets[i]], entry[offsets[i + 1]]
        off = entry[offsets[i]:offsets[i + 1] + 1] - lo
        out.append(SparseTransfer(off.astype(np.int64), np.ascontiguousarray(all_idx[lo:hi]),
                                  np.ascontiguousarray(all_val[lo:hi])))
    return out, traced


def transfer(objects: Sequence[TransferObject], cube_size: int, threshold: float, rays: int, bounces: int,
             shadowed: bool, seed: int = 0, progress: bool = False) -> list[SparseTransfer]:
    """Per object its SparseTransfer (module docstring): E(v) = sum over its entries of value x lighting[index],
    lighting the Haar coefficients of the cube level of face `cube_size`. ValueError for bad settings or inputs
    (naming the object), MemoryError when `check_memory` refuses, RuntimeError when shadowed without embreex."""
    return _transfer(objects, cube_size, threshold, rays, bounces, shadowed, seed, progress)[0]


# ---------------------------------------------------------------------------------------------- cache


def transfer_key(objects: Sequence[TransferObject], cube_size: int, threshold: float, rays_: int, bounces: int,
                 shadowed: bool, seed: int = 0) -> str:
    """Hex SHA-256 over everything that changes the transfer (module docstring)."""
    desc = {"kind": "wavelet_prt", "version": TRANSFER_VERSION, "cube_size": int(cube_size),
            "threshold": float(threshold), "bounces": int(bounces), "shadowed": bool(shadowed)}
    if bounces > 0:  # the albedos, the gather's rays and its seed enter only the bounces
        desc.update(rays=int(rays_), seed=int(seed), kd=[[float(c) for c in o.kd] for o in objects])
    return transfer_rays.cache_key(desc, objects)


def _entry_problem(t: SparseTransfer, vertices: int, coefficients: int, channels: int) -> str | None:
    """What makes stored arrays meaningless for this transfer (None: nothing)."""
    off, idx, val = t.offsets, t.indices, t.values
    if off.dtype != np.int64 or off.shape != (vertices + 1,) or off[0] != 0 or (np.diff(off) < 0).any():
        return f"offsets of shape {off.shape} {off.dtype} are not the CSR offsets of {vertices} vertices"
    if idx.dtype != np.uint32 or idx.shape != (off[-1],):
        return f"indices of shape {idx.shape} {idx.dtype} where ({off[-1]},) uint32 was expected"
    if val.dtype != np.float32 or val.shape != (off[-1], channels) or not np.isfinite(val).all():
        return f"values of shape {val.shape} {val.dtype} where ({off[-1]}, {channels}) finite float32 was expected"
    if len(idx) and idx.max() >= coefficients:
        return f"an index {idx.max()} >= {coefficients} coefficients"
    inner = np.diff(idx.astype(np.int64)) > 0
    starts = off[1:-1]
    starts = starts[(starts > 0) & (starts < len(idx))]
    inner[starts - 1] = True  # a new vertex may start lower
    if not inner.all():
        return "a vertex's indices are not strictly increasing"
    return None


def _load(path, vertices: list[int], coefficients: int, channels: int):
    """The transfers and metadata of a valid entry; None when missing. A corrupt entry, or one whose arrays mean
    nothing for this transfer (`_entry_problem`), warns and returns None (recomputed)."""
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            meta_json, stored = str(z["meta"]), str(z["checksum"])
            arrays = [z[f"{name}{i}"] for i in range(len(vertices)) for name in ("o", "i", "v")]
        if transfer_rays.entry_checksum(arrays, meta_json) != stored:
            raise ValueError("checksum mismatch")
        meta = json.loads(meta_json)
        if not isinstance(meta, dict) or meta.get("version") != TRANSFER_VERSION:
            raise ValueError(f"version {meta.get('version') if isinstance(meta, dict) else meta!r}: this iblcheck "
                             f"reads version {TRANSFER_VERSION}")
        sec, traced = meta.get("seconds"), meta.get("rays_traced")
        if isinstance(traced, bool) or not isinstance(traced, int) or traced < 0:
            raise ValueError(f"rays_traced = {traced!r}: a count >= 0 is required")
        if isinstance(sec, bool) or not isinstance(sec, (int, float)) or not np.isfinite(sec) or sec < 0:
            raise ValueError(f"seconds = {sec!r}: a finite time >= 0 is required")
        out = []
        for i, v in enumerate(vertices):
            t = SparseTransfer(*arrays[3 * i:3 * i + 3])
            problem = _entry_problem(t, v, coefficients, channels)
            if problem:
                raise ValueError(f"object {i}: {problem}")
            out.append(t)
        return out, meta
    except Exception as exc:  # any unreadable entry (truncated zip, bad checksum, ...) is recomputed
        warnings.warn(f"wavelet PRT cache entry {path} is corrupt ({exc}); recomputing it", CacheWarning,
                      stacklevel=3)
        return None


def _store(folder, key: str, transfers: list[SparseTransfer], meta: dict) -> None:
    arrays = {f"{name}{i}": a for i, t in enumerate(transfers)
              for name, a in (("o", t.offsets), ("i", t.indices), ("v", t.values))}
    meta_json = json.dumps(meta, sort_keys=True)
    try:
        checksum = transfer_rays.entry_checksum(list(arrays.values()), meta_json)
        write_npz(folder, key, meta=np.array(meta_json), checksum=np.array(checksum), **arrays)
    except OSError as exc:
        warnings.warn(f"wavelet PRT cache {folder} cannot be written ({exc.strerror or exc}); the transfer is "
                      "returned but not cached", CacheWarning, stacklevel=3)


def cached_transfer(objects: Sequence[TransferObject], cube_size: int, threshold: float, rays_: int, bounces: int,
                    shadowed: bool, seed: int = 0, progress: bool = False) -> tuple[list[SparseTransfer], dict]:
    """transfer(), cached on disk (module docstring). Returns (transfers, info), info = {"key", "cached",
    "seconds" (0 when read from the cache), "compute_seconds" (what computing it took), "rays_traced",
    "vertices", "entries" (stored coefficients), "bytes" (GPU bytes of all objects), "bytes_per_vertex"}."""
    _check_settings(int(cube_size), float(threshold), int(rays_), int(bounces), shadowed)
    checked = [transfer_rays.check_object(f"wavelet PRT object {i}", o) for i, o in enumerate(objects)]
    vertices = [len(o.positions) for o in checked]
    check_memory(sum(vertices), int(cube_size), int(bounces))  # before any cache read or trace
    key = transfer_key(objects, cube_size, threshold, rays_, bounces, shadowed, seed)
    folder = cache_dir() / "wavelet_prt"
    channels = 3 if bounces else 1
    entry = _load(folder / f"{key}.npz", vertices, 6 * int(cube_size) ** 2, channels)
    if entry is not None:
        transfers, meta = entry
        cached, seconds, compute, traced = True, 0.0, float(meta["seconds"]), int(meta["rays_traced"])
    else:
        t0 = time.perf_counter()
        transfers, traced = _transfer(objects, cube_size, threshold, rays_, bounces, shadowed, seed, progress)
        seconds = compute = time.perf_counter() - t0
        cached = False
        _store(folder, key, transfers, {"version": TRANSFER_VERSION, "seconds": seconds, "rays_traced": traced})
    total_bytes = sum(t.nbytes for t in transfers)
    return transfers, {"key": key, "cached": cached, "seconds": seconds, "compute_seconds": compute,
                       "rays_traced": traced, "vertices": sum(vertices),
                       "entries": int(sum(len(t.indices) for t in transfers)), "bytes": int(total_bytes),
                       "bytes_per_vertex": total_bytes / max(sum(vertices), 1)}
