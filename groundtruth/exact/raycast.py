"""Camera rays against the scene's triangle meshes in numpy, independent of Mitsuba and OpenGL.

Used by the quadrature reference: it finds, for every sub-pixel ray, the nearest triangle hit
(Moller & Trumbore 1997), the hit point and the interpolated vertex normal. Triangles are binned
into 4 x 4-pixel tiles by their projected bounding boxes, so each ray is tested only against
the triangles that can cover its tile (a triangle that reaches behind the camera is put in every
tile).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.environment.directions import normalize

TILE = 4
EPS_T = 1e-7


@dataclass
class Hits:
    """Per sub-pixel ray (H, W, S): whether it hit, the object, the point, the shading normal."""

    hit: np.ndarray  # (H, W, S) bool
    object_id: np.ndarray  # (H, W, S) int32, -1 where nothing was hit
    position: np.ndarray  # (H, W, S, 3) float64
    normal: np.ndarray  # (H, W, S, 3) float64, unit, interpolated vertex normals
    direction: np.ndarray  # (H, W, S, 3) float64 unit ray directions


def _scene_triangles(scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(F, 3, 3) vertices, (F, 3, 3) vertex normals, (F,) object ids over all objects."""
    verts, norms, ids = [], [], []
    for i, obj in enumerate(scene.objects):
        m = obj.mesh
        verts.append(m.positions.astype(np.float64)[m.indices])
        norms.append(m.normals.astype(np.float64)[m.indices])
        ids.append(np.full(m.n_triangles, i, dtype=np.int32))
    return np.concatenate(verts), np.concatenate(norms), np.concatenate(ids)


def _tile_ranges(camera, tri: np.ndarray) -> np.ndarray:
    """(F, 4) inclusive tile ranges (tx0, tx1, ty0, ty1) of each triangle's projected bounding box."""
    right, true_up, forward = camera.basis()
    depth = (tri - np.asarray(camera.origin)) @ forward  # (F, 3)
    n_tx = -(-camera.width // TILE)
    n_ty = -(-camera.height // TILE)
    behind = (depth <= 1e-6).any(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        px = camera.project(tri)  # (F, 3, 2) as (column, row)
    lo = np.floor(np.nan_to_num(px.min(axis=1), nan=0.0, posinf=1e9, neginf=-1e9))
    hi = np.floor(np.nan_to_num(px.max(axis=1), nan=0.0, posinf=1e9, neginf=-1e9))
    out = np.stack([lo[:, 0], hi[:, 0], lo[:, 1], hi[:, 1]], axis=1) // TILE
    out = np.clip(out, 0, [n_tx - 1, n_tx - 1, n_ty - 1, n_ty - 1]).astype(np.int64)
    out[behind] = [0, n_tx - 1, 0, n_ty - 1]
    # entirely off screen (after clipping a box that lies outside collapses onto the border): drop
    off = (hi[:, 0] < 0) | (lo[:, 0] >= camera.width) | (hi[:, 1] < 0) | (lo[:, 1] >= camera.height)
    out[off & ~behind] = [1, 0, 1, 0]  # an empty range
    return out


def cast(scene, subpixels: int = 1) -> Hits:
    """Nearest hits of the camera's k x k sub-pixel rays (k = `subpixels`) against all objects."""
    cam = scene.camera
    h, w, s = cam.height, cam.width, subpixels * subpixels
    dirs = cam.subpixel_rays(subpixels)
    origin = np.asarray(cam.origin, dtype=np.float64)
    tri, tri_n, tri_obj = _scene_triangles(scene)
    ranges = _tile_ranges(cam, tri)

    # (tile, triangle) pairs, grouped by tile
    nx = np.maximum(ranges[:, 1] - ranges[:, 0] + 1, 0)
    ny = np.maximum(ranges[:, 3] - ranges[:, 2] + 1, 0)
    count = nx * ny
    tri_idx = np.repeat(np.arange(len(tri)), count)
    local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    tx = ranges[tri_idx, 0] + local % np.repeat(np.maximum(nx, 1), count)
    ty = ranges[tri_idx, 2] + local // np.repeat(np.maximum(nx, 1), count)
    n_tx = -(-w // TILE)
    tile_of_pair = ty * n_tx + tx
    order = np.argsort(tile_of_pair, kind="stable")
    tile_sorted, tri_sorted = tile_of_pair[order], tri_idx[order]
    bounds = np.searchsorted(tile_sorted, np.arange(n_tx * (-(-h // TILE)) + 1))

    hit = np.zeros((h, w, s), dtype=bool)
    obj_id = np.full((h, w, s), -1, dtype=np.int32)
    pos = np.zeros((h, w, s, 3))
    nrm = np.zeros((h, w, s, 3))
    e1 = tri[:, 1] - tri[:, 0]
    e2 = tri[:, 2] - tri[:, 0]
    for tile in range(len(bounds) - 1):
        cand = tri_sorted[bounds[tile]:bounds[tile + 1]]
        if len(cand) == 0:
            continue
        r0, c0 = (tile // n_tx) * TILE, (tile % n_tx) * TILE
        d = dirs[r0:r0 + TILE, c0:c0 + TILE]  # (th, tw, s, 3)
        shape = d.shape[:3]
        d = d.reshape(-1, 3)
        t, b1, b2, ok = _moller_trumbore(origin, d, tri[cand, 0], e1[cand], e2[cand])
        t = np.where(ok, t, np.inf)
        best = np.argmin(t, axis=1)
        rows = np.arange(len(d))
        t_best = t[rows, best]
        got = np.isfinite(t_best)
        tri_best = cand[best]
        u, v = b1[rows, best], b2[rows, best]
        tn = tri_n[tri_best]
        n = (1.0 - u - v)[:, None] * tn[:, 0] + u[:, None] * tn[:, 1] + v[:, None] * tn[:, 2]
        sl = (slice(r0, r0 + shape[0]), slice(c0, c0 + shape[1]))
        hit[sl] = got.reshape(shape)
        obj_id[sl] = np.where(got, tri_obj[tri_best], -1).reshape(shape)
        pos[sl] = np.where(got[:, None], origin + t_best[:, None] * d, 0.0).reshape(*shape, 3)
        nrm[sl] = np.where(got[:, None], normalize(n), 0.0).reshape(*shape, 3)
    return Hits(hit=hit, object_id=obj_id, position=pos, normal=nrm, direction=dirs)


def _moller_trumbore(origin, d, v0, e1, e2):
    """Ray (origin, d[R]) x triangles (v0[T], e1[T], e2[T]) -> (t, b1, b2, ok), each (R, T)."""
    p = np.cross(d[:, None, :], e2[None, :, :])  # (R, T, 3)
    det = np.einsum("rtk,tk->rt", p, e1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = origin - v0  # (T, 3)
        b1 = np.einsum("rtk,tk->rt", p, s) * inv
        q = np.cross(s, e1)  # (T, 3)
        b2 = (d @ q.T) * inv
        t = (q * e2).sum(axis=1)[None, :] * inv
    ok = (np.abs(det) > 1e-14) & (b1 >= 0) & (b2 >= 0) & (b1 + b2 <= 1) & (t > EPS_T)
    return t, b1, b2, ok
