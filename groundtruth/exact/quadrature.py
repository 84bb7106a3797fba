"""The noise-free reference: the paper's reflectance integrated over the environment by quadrature.

    groundtruth.exact.quadrature.render(scene, subpixels=4) -> Render

For every sub-pixel ray (k x k per pixel, averaged like Mitsuba's box filter; k = 4 because a
sharp lobe reflects detail finer than a pixel, and 2 x 2 then costs ~1.5 dB) that hits an
object (raycast.py, numpy, independent of Mitsuba and OpenGL), the outgoing radiance

    L = (1 - F) kd / pi E(n) + F ks G(r, n),   E(n) = int L_env(w) max(n.w, 0) dw,
    G(r, n) = int L_env(w) (N + 1) / (2 pi) max(r.w, 0)^N [n.w > 0] dw

is summed over the cells of an equirect grid. Each cell holds the solid-angle-weighted average of
the very function Mitsuba's `envmap` emitter evaluates (bilinear, `scenes.environment.envmap.lookup`), taken
by supersampling, so no texel's energy is lost; the grid is fine enough that the kernel is smooth
over a cell (cell <= lobe width / 4). Only cells in the kernel's support are visited: shading
points are grouped by their kernel axis and each group sums the cells within the cap of radius
(support + group spread). Kernel masses are normalised by their discrete sums (pi for the
cosine, 1 for the lobe without its horizon cut), which removes the quadrature error of the kernel
itself: a constant environment is reproduced exactly, the horizon loss is kept.

Lobes narrower than the finest grid can resolve (N > ~2.6e4) are integrated in the lobe's own
frame instead (Gauss-Legendre in t = cos^(N+1) alpha, uniform in phi), where the bilinear
environment is smooth. No occlusion: exact for one convex object (docs/contract.md section 4).
"""

from __future__ import annotations

import math
import time
from functools import lru_cache

import numpy as np

from groundtruth.exact import raycast
from groundtruth.exact.reflectance import face_viewer, lobe_weights, phong_lobe, reflect
from scenes import InputError
from scenes.environment import envmap
from scenes.environment.directions import TWO_PI, normalize, rotation_y, uv_to_direction
from scenes.model.render import Render

MIN_WIDTH, MAX_WIDTH = 128, 4096
DIFFUSE_WIDTH = 128  # max error 2e-4 of the peak against a 512-wide grid on uffizi
#: the lobe is cut where it falls below this fraction of its peak
LOBE_CUTOFF = 1e-7
CHUNK = 256


# --------------------------------------------------------------------------- the cell grid


class CellGrid:
    """An equirect grid in the environment's own frame (H = W / 2, pixel-centre rows).

    `values` (H, W, 3): solid-angle-weighted cell averages of the bilinear environment;
    `omega` (H,) cell solid angles per row; `dirs` (H, W, 3) cell-centre directions.
    """

    def __init__(self, env: np.ndarray, width: int):
        self.w, self.h = width, width // 2
        theta_edges = np.linspace(0.0, np.pi, self.h + 1)
        self.theta = 0.5 * (theta_edges[:-1] + theta_edges[1:])
        self.omega = (np.cos(theta_edges[:-1]) - np.cos(theta_edges[1:])) * TWO_PI / self.w
        u = (np.arange(self.w) + 0.5) / self.w
        self.dirs = uv_to_direction(u[None, :], (self.theta / np.pi)[:, None])
        self.values = self._cell_averages(env)

    def _cell_averages(self, env: np.ndarray) -> np.ndarray:
        env_h, env_w = env.shape[:2]
        # >= 2 lookups per environment texel along each axis, counted apart: a map much wider than tall
        # (3 x 100000) needs many lookups along u only, not that many squared
        ss_u = max(1, math.ceil(2 * env_w / self.w))
        ss_v = max(1, math.ceil(2 * env_h / self.h))
        off_u = (np.arange(ss_u) + 0.5) / ss_u
        off_v = (np.arange(ss_v) + 0.5) / ss_v
        out = np.empty((self.h, self.w, 3), dtype=np.float64)
        rows_per_block = max(1, 2_000_000 // (self.w * ss_u * ss_v))
        u = ((np.arange(self.w)[:, None] + off_u[None, :]) / self.w).reshape(-1)  # (W*ss_u,)
        for r0 in range(0, self.h, rows_per_block):
            r1 = min(self.h, r0 + rows_per_block)
            v = ((np.arange(r0, r1)[:, None] + off_v[None, :]) / self.h).reshape(-1)  # (R*ss_v,)
            vals = envmap.lookup(env, uv_to_direction(u[None, :], v[:, None])).astype(np.float64)
            wt = np.sin(np.pi * v)[:, None, None]  # solid angle density within the cell
            vals = (vals * wt).reshape(r1 - r0, ss_v, self.w, ss_u, 3).sum(axis=(1, 3))
            wsum = wt.reshape(r1 - r0, ss_v).sum(axis=1) * ss_u
            out[r0:r1] = vals / np.maximum(wsum, 1e-300)[:, None, None]
        return out

    def cap(self, centre: np.ndarray, radius: float) -> np.ndarray:
        """Flat indices of the cells whose centres lie within `radius` (rad) of unit `centre`."""
        radius = min(radius, np.pi)
        theta_c = math.acos(max(-1.0, min(1.0, centre[1])))
        phi_c = math.atan2(centre[0], -centre[2]) % TWO_PI
        rows = np.nonzero(np.abs(self.theta - theta_c) <= radius)[0]
        if radius >= np.pi - 1e-12:
            rows = np.arange(self.h)
        out = []
        cos_r = math.cos(radius)
        sin_c, cos_c = math.sin(theta_c), math.cos(theta_c)
        for i in rows:
            denom = math.sin(self.theta[i]) * sin_c
            x = (cos_r - math.cos(self.theta[i]) * cos_c) / denom if denom > 1e-12 else -2.0
            if x <= -1.0:
                out.append(np.arange(self.w) + i * self.w)
                continue
            if x > 1.0:
                continue
            half = math.acos(x)
            j0 = math.ceil((phi_c - half) * self.w / TWO_PI - 0.5)
            j1 = math.floor((phi_c + half) * self.w / TWO_PI - 0.5)
            if j1 - j0 + 1 >= self.w:
                out.append(np.arange(self.w) + i * self.w)
            elif j1 >= j0:
                out.append(np.arange(j0, j1 + 1) % self.w + i * self.w)
        return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


@lru_cache(maxsize=8)
def _grid_cached(env_bytes: bytes, shape: tuple, width: int) -> CellGrid:
    return CellGrid(np.frombuffer(env_bytes, dtype=np.float32).reshape(shape), width)


def cell_grid(env: np.ndarray, width: int) -> CellGrid:
    env = np.ascontiguousarray(env, dtype=np.float32)
    return _grid_cached(env.tobytes(), env.shape, width)


def lobe_support(exponent: float) -> float:
    """Angle (rad) beyond which cos^N falls below LOBE_CUTOFF (pi for N = 0)."""
    if exponent <= 0:
        return np.pi
    c = math.exp(math.log(LOBE_CUTOFF) / exponent)
    return math.acos(c)


def lobe_width(exponent: float) -> int:
    """Grid width whose cells are at most a quarter of the lobe's angular scale 1 / sqrt(N + 1)."""
    need = 8.0 * math.pi * math.sqrt(exponent + 1.0)
    return int(min(MAX_WIDTH, max(MIN_WIDTH, 2 ** math.ceil(math.log2(need)))))


def needs_lobe_frame(exponent: float) -> bool:
    return 8.0 * math.pi * math.sqrt(exponent + 1.0) > MAX_WIDTH


# --------------------------------------------------------------------------- kernel sums


def _chunks(axes: np.ndarray, bins: int = 48):
    """Index groups of at most CHUNK shading points whose kernel axes share a (bins x 2 bins)
    equirect bin, so that a group's axes lie within a few degrees of each other."""
    u = (np.arctan2(axes[:, 0], -axes[:, 2]) % TWO_PI) / TWO_PI
    v = np.arccos(np.clip(axes[:, 1], -1, 1)) / np.pi
    key = np.minimum(np.floor(v * bins), bins - 1).astype(np.int64) * 2 * bins + np.floor(u * 2 * bins).astype(np.int64)
    order = np.argsort(key, kind="stable")
    key = key[order]
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    ends = np.r_[starts[1:], len(order)]
    for a, b in zip(starts, ends, strict=True):
        for i in range(a, b, CHUNK):
            yield order[i:min(b, i + CHUNK)]


def _integrate(grid: CellGrid, axes: np.ndarray, normals: np.ndarray, support: float, kernel) -> np.ndarray:
    """sum_cells kernel(axis . w) [n . w > 0] L dw / sum_cells kernel(axis . w) dw, per point (P, 3).

    `kernel(one_minus_cos)` takes 1 - axis.w (in float64, accurate for lobes up to N ~ 1e12).
    """
    out = np.zeros((len(axes), 3))
    flat_dirs = grid.dirs.reshape(-1, 3)
    flat_vals = grid.values.reshape(-1, 3)
    flat_omega = np.repeat(grid.omega, grid.w)
    for idx in _chunks(axes):
        a = axes[idx]
        centre = normalize(a.mean(axis=0))
        if not np.any(centre):
            centre = a[0]
        spread = float(np.arccos(np.clip(a @ centre, -1, 1)).max())
        cells = grid.cap(centre, support + spread + 2.0 * np.pi / grid.w)
        if len(cells) == 0:
            continue
        w = flat_dirs[cells]
        k = kernel(1.0 - a @ w.T) * flat_omega[cells][None, :]  # float64: 1 - a.w is exact to 1e-16
        above = (normals[idx] @ w.T) > 0
        num = (k * above) @ flat_vals[cells]
        den = k.sum(axis=1)
        out[idx] = num / np.maximum(den, 1e-300)[:, None]
    return out


def irradiance(grid: CellGrid, normals: np.ndarray) -> np.ndarray:
    """E(n) / pi: the cosine-weighted average radiance over the hemisphere of n (P, 3)."""
    return _integrate(grid, normals, normals, np.pi / 2, lambda d: np.clip(1.0 - d, 0.0, None))


def glossy(env: np.ndarray, r: np.ndarray, normals: np.ndarray, exponent: float) -> np.ndarray:
    """G(r, n): the normalised Phong lobe about r, cut at the horizon of n, over the environment (P, 3)."""
    if needs_lobe_frame(exponent):
        return _glossy_lobe_frame(env, r, normals, exponent)
    grid = cell_grid(env, lobe_width(exponent))
    return _integrate(grid, r, normals, lobe_support(exponent), lambda d: phong_lobe(d, exponent))


def _glossy_lobe_frame(env: np.ndarray, r: np.ndarray, normals: np.ndarray, exponent: float,
                       n_t: int = 8, n_phi: int = 16) -> np.ndarray:
    """Very narrow lobes: equal-weight nodes in t = cos^(N+1) alpha (the lobe's own CDF) and phi."""
    x, wx = np.polynomial.legendre.leggauss(n_t)
    t = 0.5 * (x + 1.0)
    wt = 0.5 * wx
    # 1 - cos alpha = -expm1(log(t) / (N + 1))
    one_minus = -np.expm1(np.log(t) / (exponent + 1.0))
    sin_a = np.sqrt(one_minus * (2.0 - one_minus))
    phi = (np.arange(n_phi) + 0.5) * TWO_PI / n_phi
    local = np.stack([np.outer(sin_a, np.cos(phi)), np.outer(sin_a, np.sin(phi)),
                      np.repeat((1.0 - one_minus)[:, None], n_phi, axis=1)], axis=-1).reshape(-1, 3)
    weights = np.repeat(wt, n_phi) / n_phi
    # an orthonormal frame about each r
    helper = np.where(np.abs(r[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    tx = normalize(np.cross(helper, r))
    ty = np.cross(r, tx)
    out = np.zeros((len(r), 3))
    for i in range(0, len(r), 4096):
        sl = slice(i, i + 4096)
        d = (local[None, :, 0:1] * tx[sl, None, :] + local[None, :, 1:2] * ty[sl, None, :]
             + local[None, :, 2:3] * r[sl, None, :])
        above = np.einsum("pk,pnk->pn", normals[sl], d) > 0
        vals = envmap.lookup(env, d).astype(np.float64)
        out[sl] = ((weights * above)[..., None] * vals).sum(axis=1) / weights.sum()
    return out


# --------------------------------------------------------------------------- rendering


def shade(material, env: np.ndarray, normals: np.ndarray, views: np.ndarray) -> np.ndarray:
    """Outgoing radiance (P, 3) of the paper's reflectance at points with unit `normals` seen from `views`.

    `env` is the (H, W, 3) map; normals and views are in its own (unrotated) frame, views pointing
    from the surface towards the camera.
    """
    normals, lit = face_viewer(material, normals, views)
    n_dot_v = (normals * views).sum(axis=1)
    wd, wg = lobe_weights(material, n_dot_v)
    wd, wg = wd * lit, wg * lit  # one-sided: nothing seen from behind the shading normal
    out = np.zeros((len(normals), 3))
    if material.has_diffuse:
        grid = cell_grid(env, DIFFUSE_WIDTH)
        out += wd[:, None] * np.asarray(material.kd) * irradiance(grid, normals)  # kd / pi * E, E / pi summed
    if material.has_glossy:
        r = normalize(reflect(views, normals))
        out += wg[:, None] * np.asarray(material.ks) * glossy(env, r, normals, material.exponent)
    return out


def render(scene, subpixels: int = 4) -> Render:
    """The noise-free, unoccluded reference of `scene` (see the module docstring)."""
    if scene.reference.lighting != "environment":
        raise InputError(f"{scene.path}: reference.lighting = {scene.reference.lighting!r}: the quadrature integrates "
                         "the environment map; render the light array with --renderer reference")
    t0 = time.perf_counter()
    env = scene.environment.radiance()
    rot = rotation_y(scene.environment.rotation_deg)  # env frame -> world; world -> env frame is rot.T
    hits = raycast.cast(scene, subpixels)
    t1 = time.perf_counter()
    h, w, s = hits.hit.shape
    radiance = np.zeros((h, w, s, 3))
    miss = ~hits.hit
    radiance[miss] = envmap.lookup(env, hits.direction[miss], scene.environment.rotation_deg)
    for i, obj in enumerate(scene.objects):
        sel = hits.object_id == i
        if not sel.any():
            continue
        n = hits.normal[sel] @ rot  # row-vector form of rot.T @ n
        v = -hits.direction[sel] @ rot
        radiance[sel] = shade(obj.material, env, n, v)
    t2 = time.perf_counter()
    rgb = radiance.mean(axis=2).astype(np.float32)
    mask = hits.hit.mean(axis=2) >= 0.5
    meta = {"renderer": "quadrature", "subpixels": subpixels, "occlusion": False,
            "exact_for_scene": "occlusion" not in scene.effects}
    return Render(rgb=rgb, mask=mask, timings={"raycast": (t1 - t0) * 1e3, "shade": (t2 - t1) * 1e3,
                                               "total": (t2 - t0) * 1e3}, meta=meta)
