"""The noise-free reference: the paper's reflectance (and glTF's, type "pbr") integrated over the environment
by quadrature.

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

The glTF metallic-roughness material (gltf_brdf.py) has no kernel of one axis; its section below says how it is
summed: per point, over nested grids whose cells grow with the distance from the mirror direction (GGX's tail is
too heavy for a cap), normalised by its albedos A, B and Lambert tabulated from gltf_brdf's deterministic rule.
"""

from __future__ import annotations

import math
import time
from functools import lru_cache

import numpy as np

from groundtruth.exact import gltf_brdf, raycast
from groundtruth.exact.reflectance import face_viewer, lobe_weights, phong_lobe, reflect
from scenes import InputError
from scenes.environment import envmap
from scenes.environment.directions import TWO_PI, normalize, rotation_y, uv_to_direction
from scenes.model import materials
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


# --------------------------------------------------------------------------- glTF metallic-roughness (type "pbr")
#
# f (n.l) = [f0 (1 - w) + w] K + kd (1 - w)(n.l) / pi with K = V D (n.l), w = (1 - v.h)^5 (gltf_brdf.py): three
# scalar kernels of l per shading point, none a function of one axis. Each is summed over cells as
# T(mu) sum K L dw / sum K dw, T its directional albedo (A, B or Lambert, tabulated from gltf_brdf's deterministic
# rule): a constant environment gives T(mu) exactly, and the cells only decide how the kernel weighs the
# environment. The sums run in float32 with the radiance's fourth column 1, so that numerator and denominator
# are one product and a constant environment stays exact.
#
# GGX's tail falls as 1/psi^4 away from the peak (psi the angle from r): ~1% of a roughness-0.1 lobe lies beyond
# 10 degrees, and a sun there shows, so no cap may cut it. The specular sum runs instead over nested equirect
# grids (widths W0 = 2^ceil(log2(8 pi / alpha)) down to SPEC_MIN_WIDTH; a cell of width W/2 holds four of width
# W): per point a cell of width W is used where it lies TILE of its own cells or more from r while its parent
# lies within TILE of the parent's cells (every cell of the finest grid whose parent does; every cell of the
# coarsest beyond TILE). Each point of the sphere lies in exactly one used cell, a cell is at most psi / TILE
# across (the tail's own scale is psi / 4), and a point costs ~3 pi TILE^2 cells per grid.
# Below alpha ~ 8 pi / MAX_WIDTH the peak is narrower than the finest grid resolves: there the lobe within
# theta_h < 2 theta_core of n is integrated in its own frame (gltf_brdf.half_vector_rule: the GGX CDF, the horizon
# cut exactly) against the bilinear environment, weighted by a smooth g(theta_h) whose 1 - g the finest grid takes.

SPEC_MIN_WIDTH = 32
TILE = 6
#: near grazing a point's finest grid is that of min(alpha, GRAZING mu) (see `_ggx_sums`)
GRAZING = 1.0
#: Gauss-Legendre nodes (in x, in the azimuth) of the lobe-frame core and of its blend into the finest grid
CORE_NODES = ((6, 12), (3, 8))
#: shading points x cells per batch
PAIRS = 1 << 20


def ggx_width(alpha: float) -> int:
    """Finest grid width for a GGX lobe: cells at most alpha / 4 across (the peak's log-slope in l is ~1 / alpha)."""
    need = 8.0 * math.pi / alpha
    return int(min(MAX_WIDTH, max(SPEC_MIN_WIDTH, 2 ** math.ceil(math.log2(need)))))


def ggx_needs_lobe_frame(alpha: float) -> bool:
    return 8.0 * math.pi / alpha > MAX_WIDTH


def shade_pbr(material, env: np.ndarray, normals: np.ndarray, views: np.ndarray) -> np.ndarray:
    """Outgoing radiance (P, 3) of a glTF metallic-roughness material (see `shade`)."""
    normals, lit = face_viewer(material, normals, views)
    mu = np.sum(normals * views, axis=1)
    sel = lit & (mu > 0)
    out = np.zeros((len(normals), 3))
    if not sel.any():
        return out
    n, v, m = normals[sel], views[sel], np.minimum(mu[sel], 1.0)
    alpha = materials.pbr_alpha(material.roughness)
    f0, kd = gltf_brdf.colour_weights(material.base_color, material.metallic)
    table_a, table_b = gltf_brdf.dfg_interpolated(m, alpha)
    mean_a, mean_b = _ggx_means(env, n, v, m, alpha)
    res = f0 * (table_a[:, None] * mean_a) + table_b[:, None] * mean_b
    if materials.has_diffuse(material):
        mean_d = _lambert_mean(env, n, v)
        res = res + kd * (gltf_brdf.lambert_interpolated(m)[:, None] * mean_d)
    out[sel] = res
    return out


@lru_cache(maxsize=8)
def _values4_cached(env_bytes: bytes, shape: tuple, width: int, doubled: bool) -> np.ndarray:
    grid = _grid_cached(env_bytes, shape, width)
    out = np.ones((grid.h, 2 * grid.w if doubled else grid.w, 4), dtype=np.float32)
    out[:, :grid.w, :3] = grid.values
    if doubled:
        out[:, grid.w:, :3] = grid.values
    return out.reshape(-1, 4)


def _values4(env: np.ndarray, width: int, doubled: bool = False) -> np.ndarray:
    """A cell grid's values as float32 (H W, 4), the fourth column 1 (each sum's own denominator); `doubled`:
    each row twice over (H 2W, 4), so that a column index j + c with j, c < W needs no wrapping."""
    env = np.ascontiguousarray(env, dtype=np.float32)
    return _values4_cached(env.tobytes(), env.shape, width, doubled)


def _dots(a: np.ndarray, d: np.ndarray) -> np.ndarray:
    """a (P, 3) . d (K, 3) -> (P, K), elementwise (a product with 3 inner terms is slow in BLAS)."""
    return a[:, 0:1] * d[None, :, 0] + a[:, 1:2] * d[None, :, 1] + a[:, 2:3] * d[None, :, 2]


def _lambert_mean(env: np.ndarray, n: np.ndarray, v: np.ndarray) -> np.ndarray:
    """sum (n.l)(1 - w) L dw / sum (n.l)(1 - w) dw over the cells above each point's horizon (P, 3), on the
    DIFFUSE_WIDTH grid (the paper's irradiance grid), points grouped by normal as `_integrate` does."""
    grid = cell_grid(env, DIFFUSE_WIDTH)
    vals4 = _values4(env, DIFFUSE_WIDTH)
    flat_dirs = grid.dirs.reshape(-1, 3).astype(np.float32)
    flat_omega = np.repeat(grid.omega, grid.w).astype(np.float32)
    n32, v32 = n.astype(np.float32), v.astype(np.float32)
    out = np.zeros((len(n), 3))
    for idx in _chunks(n):
        a = n[idx]
        centre = normalize(a.mean(axis=0))
        if not np.any(centre):
            centre = a[0]
        spread = float(np.arccos(np.clip(a @ centre, -1, 1)).max())
        cells = grid.cap(centre, 0.5 * np.pi + spread + 2.0 * np.pi / grid.w)
        d = flat_dirs[cells]
        nl = _dots(n32[idx], d)
        x = 1.0 - np.sqrt(np.maximum(0.5 + 0.5 * _dots(v32[idx], d), 0.0))
        x2 = x * x
        k = np.maximum(nl, 0.0) * (1.0 - x2 * x2 * x) * flat_omega[cells][None, :]
        s = k @ vals4[cells]
        out[idx] = s[:, :3] / np.maximum(s[:, 3:4].astype(np.float64), 1e-300)
    return out


def _ggx_means(env: np.ndarray, n: np.ndarray, v: np.ndarray, mu: np.ndarray,
               alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """(sum K (1 - w) L / sum K (1 - w), sum K w L / sum K w) per point (P, 3) each: the grids and the core."""
    r = normalize(2.0 * mu[:, None] * n - v)
    acc = _ggx_sums(env, n, v, r, mu, alpha)
    ok = acc[:, :, 3] > 0
    means = acc[:, :, :3] / np.where(ok, acc[:, :, 3], 1.0)[..., None]
    if not ok.all():  # a lobe with no cell above the horizon (mu ~ 0): its albedo times L(r)
        means = np.where(ok[..., None], means, envmap.lookup(env, r).astype(np.float64)[:, None, :])
    return means[:, 0], means[:, 1]


def _ggx_sums(env: np.ndarray, n: np.ndarray, v: np.ndarray, r: np.ndarray, mu: np.ndarray,
              alpha: float) -> np.ndarray:
    """(P, 2, 4): per kernel K (1 - w), K w the sums of K L (3 channels) and of K (the quadrature's own
    estimate of A and B) over the core and the used cells of every grid."""
    acc = np.zeros((len(n), 2, 4))
    core = ggx_needs_lobe_frame(alpha)
    theta_core = 4.0 * TWO_PI / MAX_WIDTH if core else 0.0  # 1 - g rises over [1, 2] theta_core: 8 cells in l
    if core:
        _ggx_core(env, n, v, mu, alpha, theta_core, acc)
    # near grazing K = V D (n.l) changes over n.l ~ mu at the horizon (V ~ 1 / (2 alpha (mu + n.l)) for
    # n.l << alpha), which the lobe's own scale alpha does not see: those points take the grid of min(alpha, mu)
    finest = np.array([ggx_width(a) for a in np.minimum(alpha, GRAZING * np.maximum(mu, 1e-6))])
    for w0 in np.unique(finest):
        sel = np.flatnonzero(finest == w0)
        widths = []
        w = int(w0)
        while w >= SPEC_MIN_WIDTH:
            widths.append(w)
            w //= 2
        sub = np.zeros((len(sel), 2, 4))
        for j, width in enumerate(widths):
            _ggx_level(env, width, n[sel], v[sel], r[sel], mu[sel], alpha, sub, finest=j == 0,
                       coarsest=j == len(widths) - 1, theta_core=theta_core if j == 0 else 0.0)
        acc[sel] += sub
    return acc


def _core_blend(cos_t: np.ndarray, sin_t: np.ndarray, theta_core: float) -> np.ndarray:
    """g(theta_h): 1 up to theta_core, 0 from 2 theta_core, smoothstep between (C1)."""
    t = np.clip(np.arctan2(sin_t, cos_t) / theta_core - 1.0, 0.0, 1.0)
    return 1.0 - t * t * (3.0 - 2.0 * t)


def _ggx_core(env: np.ndarray, n: np.ndarray, v: np.ndarray, mu: np.ndarray, alpha: float, theta_core: float,
              acc: np.ndarray) -> None:
    """Adds int K g L dl and int K g dl (g = `_core_blend`) by the lobe-frame rule, per kernel (1 - w, w)."""
    t1 = v - mu[:, None] * n
    t1_len = np.linalg.norm(t1, axis=1)
    helper = np.where(np.abs(n[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    t1 = np.where((t1_len > 1e-12)[:, None], t1 / np.maximum(t1_len, 1e-300)[:, None],
                  normalize(np.cross(helper, n)))  # v = n: the lobe is symmetric, any tangent
    t2 = np.cross(n, t1)
    for (lo, hi), (n_w, n_phi) in zip(((0.0, theta_core), (theta_core, 2.0 * theta_core)), CORE_NODES, strict=True):
        for i in range(0, len(n), 4096):
            sl = slice(i, i + 4096)
            rule = gltf_brdf.half_vector_rule(mu[sl], alpha, lo, hi, n_w, n_phi)
            f = gltf_brdf.lobe_integrand(rule, mu[sl], alpha)
            weight = rule["weight"] * f["k"]
            if lo > 0:
                weight = weight * _core_blend(rule["cos_t"], rule["sin_t"], theta_core)
            p, k = np.nonzero(weight > 0)  # the empty pieces (most points see no horizon) cost no lookups
            loc = f["l"][p, k]
            world = loc[:, 0:1] * t1[sl][p] + loc[:, 1:2] * t2[sl][p] + loc[:, 2:3] * n[sl][p]
            radiance = envmap.lookup(env, world).astype(np.float64)
            wk = weight[p, k]
            rows = p + i
            for c, part in enumerate((wk * (1.0 - f["w"][p, k]), wk * f["w"][p, k])):
                acc[:, c, 3] += np.bincount(rows, part, minlength=len(n))
                for ch in range(3):
                    acc[:, c, ch] += np.bincount(rows, part * radiance[:, ch], minlength=len(n))


@lru_cache(maxsize=16)
def _grid_dirs(width: int) -> np.ndarray:
    """Cell-centre directions (H, W, 3) of a width-`width` cell grid (CellGrid.dirs without the environment)."""
    h = width // 2
    return uv_to_direction(((np.arange(width) + 0.5) / width)[None, :], ((np.arange(h) + 0.5) / h)[:, None])


@lru_cache(maxsize=8192)
def _stencil(width: int, row: int, inner: float, outer: float) -> tuple[np.ndarray, ...]:
    """The cells of a width-`width` grid whose centres lie between `inner` and `outer` (rad) of the centre of cell
    (row, 0): (rows, cols, directions (K, 3) float32, parent directions (2, K, 3) float32 for a point in an even /
    odd column, in the frame that turns that column onto column 0)."""
    h = width // 2
    dirs = _grid_dirs(width)
    centre = dirs[row, 0]
    theta = (np.arange(h) + 0.5) * (np.pi / h)
    theta_c = theta[row]
    rows = np.nonzero(np.abs(theta - theta_c) <= outer + 1e-9)[0]
    # the azimuth half-width of the cap on each row (CellGrid.cap's formula), a little wide; exact test below
    with np.errstate(divide="ignore", invalid="ignore"):
        x = ((math.cos(outer + 1e-9) - np.cos(theta[rows]) * math.cos(theta_c))
             / (np.sin(theta[rows]) * math.sin(theta_c)))
    full = ~(x > -1.0)  # NaN (a pole) or the whole row
    half = np.arccos(np.clip(x, -1.0, 1.0))
    phi_c = np.pi / width
    j0 = np.where(full, 0, np.ceil((phi_c - half) * width / TWO_PI - 0.5)).astype(np.int64)
    j1 = np.where(full, width - 1, np.floor((phi_c + half) * width / TWO_PI - 0.5)).astype(np.int64)
    j1 = np.minimum(j1, j0 + width - 1)
    length = np.maximum(j1 - j0 + 1, 0)
    rr = np.repeat(rows, length)
    cc = (np.repeat(j0, length) + np.arange(length.sum()) - np.repeat(np.cumsum(length) - length, length)) % width
    c = dirs[rr, cc] @ centre
    keep = (c >= math.cos(outer)) & ((c <= math.cos(inner)) if inner > 0 else True)
    rr, cc = rr[keep], cc[keep]
    d = dirs[rr, cc]
    half_w = width // 2
    v_par = (rr // 2 + 0.5) / (h // 2) if h >= 2 else np.full(len(rr), 0.5)
    parents = np.stack([uv_to_direction((cc // 2 + 0.5) / half_w, v_par),
                        uv_to_direction(((cc + 1) // 2 + 0.5) / half_w - 1.0 / width, v_par)])
    return rr, cc, d.astype(np.float32), parents.astype(np.float32)


def _ggx_level(env: np.ndarray, width: int, n: np.ndarray, v: np.ndarray, r: np.ndarray, mu: np.ndarray,
               alpha: float, acc: np.ndarray, finest: bool, coarsest: bool, theta_core: float) -> None:
    """Adds the used cells of the width-`width` grid (see the section comment) to each point's sums.

    Points are grouped by the grid row holding r; each is turned about +Y so that its column is column 0, and
    its group shares one stencil of cells (their directions, and their parents' for even / odd columns): only the
    cell values are gathered per point. float32: sin^2(theta_h) comes from |n x (v + l)|^2, free of the
    cancellation of 1 - (n.h)^2 at a sharp peak."""
    grid = cell_grid(env, width)
    # one 16-byte item per cell: np.take of those is ~5x faster than indexing the (N, 4) float32 rows
    cells16 = _values4(env, width, doubled=True).view(np.complex128).reshape(-1)
    cell = TWO_PI / width
    tau = TILE * cell  # this grid's cells are used from here out (unless it is the finest) ...
    tau_parent = 2.0 * tau  # ... while their parent lies within this (unless it is the coarsest)
    inner = 0.0 if finest else max(tau - cell, 0.0)  # r lies within cell / sqrt(2) of its cell's centre
    outer = np.pi if coarsest else tau_parent + 3.0 * cell  # and a parent's centre 2 cell / sqrt(2) from a child's
    theta_r = np.arccos(np.clip(r[:, 1], -1.0, 1.0))
    phi_r = np.arctan2(r[:, 0], -r[:, 2]) % TWO_PI
    row = np.minimum((theta_r / np.pi * grid.h).astype(np.int64), grid.h - 1)
    col = np.minimum((phi_r / cell).astype(np.int64), width - 1)
    cd, sd = np.cos(col * cell), np.sin(col * cell)

    def turn(a: np.ndarray) -> np.ndarray:  # about +Y by -col * cell: column col -> column 0
        return np.stack([a[:, 0] * cd + a[:, 2] * sd, a[:, 1], a[:, 2] * cd - a[:, 0] * sd], axis=1)

    nt, vt, rt = turn(n), turn(v), turn(r)
    nxv = np.cross(nt, vt).astype(np.float32)
    nt, vt, rt = nt.astype(np.float32), vt.astype(np.float32), rt.astype(np.float32)
    mu2 = (2.0 * mu).astype(np.float32)
    mu32 = mu.astype(np.float32)
    cos_tau, cos_parent = np.float32(math.cos(tau)), np.float32(math.cos(tau_parent))
    key = row * 2 + (col & 1)
    order = np.argsort(key, kind="stable")
    starts = np.flatnonzero(np.r_[True, key[order][1:] != key[order][:-1]])
    ends = np.r_[starts[1:], len(order)]
    for a, b in zip(starts, ends, strict=True):
        members = order[a:b]
        i0, parity = divmod(int(key[members[0]]), 2)
        rows, cols, d, parents = _stencil(width, i0, inner, float(outer))
        if len(rows) == 0:
            continue
        omega = grid.omega[rows].astype(np.float32)
        offset = rows * (2 * width) + cols
        step = max(1, PAIRS // len(rows))
        for s in range(0, len(members), step):
            p = members[s:s + step]
            nl = _dots(nt[p], d)
            vl = _dots(vt[p], d)
            mask = nl > 0
            if not finest:  # r.l = 2 mu n.l - v.l
                mask &= mu2[p][:, None] * nl - vl <= cos_tau
            if not coarsest:
                mask &= _dots(rt[p], parents[parity]) > cos_parent
            # sin^2(theta_h) = |n x (v + l)|^2 / |v + l|^2, |v + l|^2 = 2 (1 + v.l)
            q, e = nt[p], nxv[p]
            cx = e[:, 0:1] + (q[:, 1:2] * d[None, :, 2] - q[:, 2:3] * d[None, :, 1])
            sin2 = cx * cx
            cx = e[:, 1:2] + (q[:, 2:3] * d[None, :, 0] - q[:, 0:1] * d[None, :, 2])
            sin2 += cx * cx
            cx = e[:, 2:3] + (q[:, 0:1] * d[None, :, 1] - q[:, 1:2] * d[None, :, 0])
            sin2 += cx * cx
            sin2 *= 0.5 / np.maximum(1.0 + vl, 1e-30)
            np.minimum(sin2, 1.0, out=sin2)
            k, w = gltf_brdf.kernels(mu32[p][:, None], nl, vl, alpha, sin2_h=sin2)
            if theta_core > 0:
                k *= 1.0 - _core_blend(np.sqrt(1.0 - sin2), np.sqrt(sin2), theta_core)
            k *= np.where(mask, omega[None, :], np.float32(0.0))
            kk = np.empty((len(p), 2, len(rows)), dtype=np.float32)
            np.multiply(k, w, out=kk[:, 1])
            np.subtract(k, kk[:, 1], out=kk[:, 0])
            vals = np.take(cells16, offset[None, :] + col[p][:, None], mode="clip")
            acc[p] += kk @ vals.view(np.float32).reshape(len(p), len(rows), 4)


# --------------------------------------------------------------------------- rendering


def shade(material, env: np.ndarray, normals: np.ndarray, views: np.ndarray) -> np.ndarray:
    """Outgoing radiance (P, 3) of the paper's reflectance at points with unit `normals` seen from `views`.

    `env` is the (H, W, 3) map; normals and views are in its own (unrotated) frame, views pointing
    from the surface towards the camera.
    """
    if material.type == "pbr":
        return shade_pbr(material, env, normals, views)
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


class NotTheReference(UserWarning):
    """The quadrature rendered a scene whose objects shadow or reflect each other (or themselves): it ignores
    that, so its image is not the scene's reference."""


def inexact_for(scene) -> str | None:
    """Why the quadrature's image is not `scene`'s reference (None when it is): it integrates the environment
    unoccluded, exact for one convex object only (the scene's `occlusion` effect)."""
    if "occlusion" not in scene.effects:
        return None
    why = (f"{len(scene.objects)} objects" if len(scene.objects) > 1 else "a non-convex object")
    return (f"{scene.name}: the quadrature ignores occlusion and interreflection, which {why} cause here; its "
            "image is not this scene's reference (use the path tracer: --renderer reference)")


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
