"""Conservative voxelisation of a triangle mesh on a cubic grid, in numpy: the voxel set every storage
structure of the experiment is built from.

A voxel (i, j, k) is the closed box [i, i + 1] x [j, j + 1] x [k, k + 1] in grid units
(x_grid = (x_world - origin) / voxel). It is set when at least one triangle overlaps it (conservative
voxelisation: no voxel a triangle touches is missed, a triangle grazing a face marks both voxels).

Overlap is the separating axis test of Akenine-Moeller, "Fast 3D triangle-box overlap testing" (Journal
of Graphics Tools 6(1), 2001): a triangle and a box are disjoint iff they are separated along one of 13
axes: the box's 3 face normals, the triangle's normal and the 9 cross products e_j x f_k of a box axis
with a triangle edge. Along an axis a the box (centre c, half-size 1/2) projects onto
[a.c - r, a.c + r] with r = (|a_x| + |a_y| + |a_z|) / 2, the triangle onto [min_i a.v_i, max_i a.v_i];
separated iff these intervals do not meet. Here:
- the 3 box axes hold by construction: the candidates are exactly the voxels whose closed boxes meet the
  triangle's bounding box (i from ceil(min) - 1 to floor(max), clipped to the grid);
- per triangle: lo_a = min_i a.v_i - r_a, hi_a = max_i a.v_i + r_a (a per-triangle constant for each of the
  10 other axes); per candidate: q = a.c, overlapping along a iff lo_a <= q <= hi_a. The plane (a = n)
  test runs first and removes most candidates of a large triangle; the 9 edge axes run on its survivors.
A margin of EPS (grid units) widens every interval, so rounding never drops a touching voxel.

Work and memory: candidates are generated and tested in chunks of at most `chunk` (a triangle whose
bounding box holds more voxels is cut into slabs along x), so the working memory is about 200 bytes x
chunk whatever the scene; `max_candidates` refuses, before any work, a voxelisation whose bounding boxes
hold more candidates than that (VoxelBudgetError, naming the resolution).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.storage.errors import InputError

#: interval margin in grid units (a voxel is 1): rounding of the float64 projections is far below it
EPS = 1e-9
#: default chunk of candidate voxels tested at once (about 100 MB of temporaries)
CHUNK = 1 << 19
#: default refusal: bounding boxes holding more candidate voxels than this (hours of numpy work)
MAX_CANDIDATES = 2_000_000_000


class VoxelBudgetError(InputError):
    """A voxelisation would test more candidate voxels than allowed."""


@dataclass(frozen=True)
class Grid:
    origin: tuple[float, float, float]  # world position of the grid's corner (voxel (0, 0, 0)'s lower corner)
    voxel: float  # edge of a voxel (world units)
    resolution: int  # voxels along each axis

    @property
    def extent(self) -> float:
        return self.voxel * self.resolution


@dataclass(frozen=True)
class VoxelSet:
    """The set voxels of a resolution^3 grid: sorted unique linear ids (x r + y) r + z, int64."""
    resolution: int
    ids: np.ndarray

    @property
    def count(self) -> int:
        return int(len(self.ids))

    def coords(self) -> np.ndarray:
        """(N, 3) int64 voxel coordinates (x, y, z)."""
        r = self.resolution
        return np.stack([self.ids // (r * r), (self.ids // r) % r, self.ids % r], 1)


def cube_grid(lo, hi, resolution: int, margin: float = 1e-3) -> Grid:
    """A cubic grid centred on the box [lo, hi], its edge the box's longest side times (1 + margin)."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    edge = max(float((hi - lo).max()) * (1.0 + margin), 1e-9)
    centre = (lo + hi) / 2.0
    return Grid(tuple(float(x) for x in centre - edge / 2.0), edge / resolution, int(resolution))


def ids_of(coords: np.ndarray, resolution: int) -> np.ndarray:
    c = np.asarray(coords, dtype=np.int64)
    return (c[:, 0] * resolution + c[:, 1]) * resolution + c[:, 2]


def _edge_axes(v: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, int]]:
    """For each of the 9 axes e_j x f_k: (its two nonzero components, lo, hi, which centre components they
    multiply). e_x x f = (0, -f_z, f_y), e_y x f = (f_z, 0, -f_x), e_z x f = (-f_y, f_x, 0). Per-vertex
    coordinate columns are made contiguous once: the (F, 3, 3) reductions were most of the time at 1e6
    triangles."""
    col = [[np.ascontiguousarray(v[:, i, c]) for c in range(3)] for i in range(3)]
    out = []
    for k in range(3):
        f = [col[(k + 1) % 3][c] - col[k][c] for c in range(3)]
        for j in range(3):
            p, q = (j + 1) % 3, (j + 2) % 3  # the nonzero components of e_j x f
            ap, aq = -f[q], f[p]
            p0, p1, p2 = (ap * col[i][p] + aq * col[i][q] for i in range(3))
            r = 0.5 * (np.abs(ap) + np.abs(aq)) + EPS
            out.append((ap, aq, np.minimum(np.minimum(p0, p1), p2) - r, np.maximum(np.maximum(p0, p1), p2) + r,
                        p, q))
    return out


def candidate_boxes(t: np.ndarray, resolution: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(kept triangle ids, imin (F', 3), counts (F', 3)) of the voxels whose closed boxes meet each
    triangle's bounding box, clipped to the grid (triangles wholly outside it dropped)."""
    lo = np.minimum(np.minimum(t[:, 0], t[:, 1]), t[:, 2])
    hi = np.maximum(np.maximum(t[:, 0], t[:, 1]), t[:, 2])
    inside = (hi >= 0).all(axis=1) & (lo <= resolution).all(axis=1)
    keep = np.flatnonzero(inside)
    imin = np.clip(np.ceil(lo[keep]) - 1, 0, resolution - 1).astype(np.int64)
    imax = np.clip(np.floor(hi[keep]), 0, resolution - 1).astype(np.int64)
    return keep, imin, imax - imin + 1


def voxelize(triangles: np.ndarray, grid: Grid, chunk: int = CHUNK,
             max_candidates: int = MAX_CANDIDATES) -> VoxelSet:
    """The conservative voxel set of `triangles` (F, 3, 3) world positions on `grid`."""
    r = grid.resolution
    t = (np.asarray(triangles, dtype=np.float64) - np.asarray(grid.origin)) / grid.voxel
    keep, imin, n = candidate_boxes(t, r)
    counts = n[:, 0] * n[:, 1] * n[:, 2]
    total = int(counts.sum())
    if total > max_candidates:
        raise VoxelBudgetError(f"voxelisation at resolution {r}: the triangles' bounding boxes hold {total:.3g} "
                               f"candidate voxels, more than the limit of {max_candidates:.3g}; use a lower resolution")
    if len(keep) == 0:
        return VoxelSet(r, np.zeros(0, dtype=np.int64))
    t = t[keep]
    chunk = max(int(chunk), r * r)
    # items: (triangle, first voxel, extent); a triangle over `chunk` candidates is cut into x slabs
    per_x = n[:, 1] * n[:, 2]
    slab = np.maximum(1, chunk // per_x)
    pieces = -(-n[:, 0] // slab)
    item_tri = np.repeat(np.arange(len(t)), pieces)
    first_piece = np.repeat(np.cumsum(pieces) - pieces, pieces)
    piece_no = np.arange(len(item_tri)) - first_piece
    item_min = imin[item_tri].copy()
    item_min[:, 0] += piece_no * slab[item_tri]
    item_n = n[item_tri].copy()
    item_n[:, 0] = np.minimum(slab[item_tri], imin[item_tri, 0] + n[item_tri, 0] - item_min[:, 0])
    item_count = item_n[:, 0] * item_n[:, 1] * item_n[:, 2]

    # per-triangle constants of the 10 axes
    normal = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    plane_d = np.einsum("fk,fk->f", normal, t[:, 0])
    plane_r = 0.5 * (np.abs(normal[:, 0]) + np.abs(normal[:, 1]) + np.abs(normal[:, 2])) + EPS
    edges = _edge_axes(t)

    found = []
    ends = np.cumsum(item_count)
    start = 0
    while start < len(item_tri):
        stop = int(np.searchsorted(ends, (ends[start - 1] if start else 0) + chunk, side="right"))
        stop = max(stop, start + 1)
        found.append(_test_items(item_tri[start:stop], item_min[start:stop], item_n[start:stop],
                                 item_count[start:stop], normal, plane_d, plane_r, edges, r))
        start = stop
    ids = np.concatenate(found)
    ids.sort()
    return VoxelSet(r, ids[np.r_[True, ids[1:] != ids[:-1]]] if len(ids) else ids)


def _test_items(tri, imin, n, count, normal, plane_d, plane_r, edges, r: int) -> np.ndarray:
    """Linear ids of the candidate voxels of these items that pass the plane and the 9 edge axes."""
    total = int(count.sum())
    item = np.repeat(np.arange(len(tri)), count)
    local = np.arange(total, dtype=np.int64) - np.repeat(np.cumsum(count) - count, count)
    ny, nz = n[item, 1], n[item, 2]
    iz = local % nz
    rest = local // nz
    iy = rest % ny
    ix = rest // ny
    ix += imin[item, 0]
    iy += imin[item, 1]
    iz += imin[item, 2]
    f = tri[item]
    c = (ix + 0.5, iy + 0.5, iz + 0.5)
    nf = normal[f]
    s = nf[:, 0] * c[0] + nf[:, 1] * c[1] + nf[:, 2] * c[2] - plane_d[f]
    ok = np.abs(s) <= plane_r[f]
    ix, iy, iz, f = ix[ok], iy[ok], iz[ok], f[ok]
    c = (ix + 0.5, iy + 0.5, iz + 0.5)
    ok = np.ones(len(f), dtype=bool)
    for ap, aq, lo, hi, p, q in edges:
        proj = ap[f] * c[p] + aq[f] * c[q]
        ok &= (proj >= lo[f]) & (proj <= hi[f])
    ids = ((ix[ok] * r + iy[ok]) * r + iz[ok])
    return np.unique(ids)
