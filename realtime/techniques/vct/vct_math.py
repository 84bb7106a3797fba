"""The numpy half of voxel cone tracing (realtime/techniques/vct/vct.py; docs/contract.md section 9): what a test
or the GPU side needs without GL.

- `cone_set(n)`: the diffuse cones (directions in the normal's frame, half-angles whose solid angles sum
  to the hemisphere's 2 pi, weights that sum to pi) for 4, 6 or 9 cones, a quadrature of the irradiance
  exact for every radiance of spherical-harmonic order <= 2.
- `step_transmittance`: what one step of a cone lets through a texel (Beer-Lambert per axis, the optical
  depths weighted by the direction's absolute cosines; vct_trace.glsl's `vct_step_transmittance`).
- `glossy_half_angle(exponent)`: the glossy cone follows the Phong exponent: its solid angle
  2 pi (1 - cos a) is the lobe's 2 pi / (N + 1) (McGuire et al. 2013), clamped to [1, 30] degrees.
- `Cascades`: nested cubic grids, each twice the extent of the one inside it, centred on the objects;
  `level_of` is the seed's level selection (the cone's diameter picks the cascade and its mip).
- `footprint_cap` and `sample_lod`: the level a cone sample reads (vct_trace.glsl's `vct_cone`): the
  cone's diameter, capped where the lookup would reach the voxels of the surface the cone leaves.
- `max_cone_samples`: the loop bound that lets every cone reach the outermost cascade's boundary.
- `anisotropic_mip`: one level of the six-face mip (front-to-back along each axis, then averaged, the radiance
  over the opacity of the pairs that are not a surface's back),
  the reference the GPU's vct_mip.comp is tested against.
- `normal_mip`: one level of the six face-normal textures' mip (the normal of what a viewer on each face's side
  sees, weighted as the faces composite their opacity), the reference for vct_normal_mip.comp.
- `surface_voxel_bound`: the 4 pi r^2 / h^2 bound of a sphere's shell.
- `sum_scale`: the voxeliser's fixed-point scales, lowered where a crowded voxel could overflow int32.
- `radiance_scale`: the power of two the faces' radiance is stored times, so that a bright sun fits half float.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np

from scenes.environment import cubemap

#: cone counts `[realtime.vct] diffuse_cones` may take
CONE_COUNTS = (4, 6, 9)
#: the glossy cone's half-angle is clamped to this range (degrees)
GLOSSY_HALF_ANGLE_RANGE = (1.0, 30.0)
#: face order of the six directional values: +X, -X, +Y, -Y, +Z, -Z (a face holds what leaves the voxel
#: toward that direction, so a cone travelling along d reads the faces that point against d)
FACES = ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1))


@dataclass(frozen=True)
class ConeSet:
    directions: np.ndarray  # (n, 3) in the normal's frame (z = the normal)
    half_angle: float  # radians, the same for every cone of the set
    weights: np.ndarray  # (n,) each cone's weight in the irradiance sum_k w_k L_k; sum = pi


def half_angle_for(count: int) -> float:
    """Cones whose solid angles sum to the hemisphere: n cones of half-angle a cover 2 pi n (1 - cos a) =
    2 pi, so cos a = 1 - 1 / n (6 cones: 33.56 degrees, where the seed's 30 degrees leave a fifth of the
    hemisphere, 2 pi - 6 * 2 pi (1 - cos 30 deg) = 1.23 sr, to no cone)."""
    return math.acos(1.0 - 1.0 / count)


def ring_directions(count: int, cos_polar: float) -> np.ndarray:
    """(count, 3) unit directions in the normal's frame (z = the normal): one along it, then count - 1 at polar
    angle acos(cos_polar), azimuths 2 pi k / (count - 1) from +x."""
    ring = count - 1
    s = math.sqrt(1.0 - cos_polar * cos_polar)
    phi = 2.0 * math.pi * np.arange(ring) / ring
    around = np.stack([s * np.cos(phi), s * np.sin(phi), np.full(ring, cos_polar)], -1)
    return np.concatenate([[[0.0, 0.0, 1.0]], around])


# The diffuse cones as a quadrature of the irradiance E(n) = int_H L(w) (n . w) dw: one cone along n and
# count - 1 in a ring at polar angle theta (azimuths 2 pi k / (count - 1)), weights w_0 and w_r = (pi - w_0) /
# (count - 1), each cone reading the mean of L over its cap of half-angle a (half_angle_for). The rule is made
# exact for every radiance of spherical-harmonic order l <= 2, the orders that carry nearly all of the
# irradiance (Ramamoorthi and Hanrahan 2001, "An efficient representation for irradiance environment maps": the
# clamped cosine's coefficients are pi, 2 pi / 3, pi / 4, 0, -pi / 24, ... for l = 0, 1, 2, 3, 4).
# - A cap's mean of any Y_lm about its axis d is lambda_l Y_lm(d) (Funk-Hecke), lambda_l the cap's mean of
#   P_l(cos g), g in [0, a] uniform in solid angle: lambda_0 = 1, lambda_1 = (1 + cos a) / 2,
#   lambda_2 = cos a (1 + cos a) / 2 (the integral of (3 t^2 - 1) / 2 over [cos a, 1], over 1 - cos a).
# - A term Y_lm with m != 0 integrates to 0 against the cosine (azimuthal symmetry about n); the cone along n
#   reads lambda_l Y_lm(n) = 0 of it, and the ring's cones lambda_l Y_lm(d_k), whose sum over count - 1 >= 3
#   equally spaced azimuths is 0 for |m| <= 2. The m = 0 terms are the Legendre polynomials P_l(n . w).
# - The exact integrals of P_0, P_1, P_2 against the cosine over the hemisphere are pi, 2 pi / 3, pi / 4.
# With W = w_0 / pi and c = cos(theta) the three conditions are
#   l = 0:  w_0 + (count - 1) w_r = pi                                  (the weights sum to pi)
#   l = 1:  lambda_1 (W + (1 - W) c) = 2 / 3
#   l = 2:  lambda_2 (W + (1 - W) (3 c^2 - 1) / 2) = 1 / 4
# With a1 = (2/3) / lambda_1 and a2 = (1/4) / lambda_2: l = 1 gives (1 - W)(1 - c) = 1 - a1, and l = 1 minus
# l = 2, (1 - W)(1 - c)(1 + 3 c) / 2 = a1 - a2, so c = (2 (a1 - a2) / (1 - a1) - 1) / 3 and
# W = 1 - (1 - a1) / (1 - c). Six cones: the ring at 49.9 deg, w_0 = 0.233 pi, w_r = 0.153 pi; four: 42.8 deg,
# 0.107 pi, 0.298 pi; nine: 53.7 deg, 0.280 pi, 0.090 pi. Every ring's caps stay above the horizon (at most
# 84.2 deg from n). The seed's ring at 60 deg with each cone weighted by its Voronoi cell's cosine integral is
# exact for l = 0 only: it reads the irradiance of L = n . w 12 % low (0.585 pi against 2 pi / 3).
@cache
def cone_set(count: int) -> ConeSet:
    """One cone along the normal and count - 1 in a ring, half-angles whose solid angles sum to the hemisphere,
    the ring's polar angle and the weights (sum pi) those that integrate every radiance of spherical-harmonic
    order <= 2 exactly (the derivation above)."""
    if count not in CONE_COUNTS:
        raise ValueError(f"diffuse_cones must be one of {CONE_COUNTS}, got {count}")
    a = half_angle_for(count)
    cos_a = math.cos(a)
    a1 = (2.0 / 3.0) / ((1.0 + cos_a) / 2.0)
    a2 = 0.25 / (cos_a * (1.0 + cos_a) / 2.0)
    c = (2.0 * (a1 - a2) / (1.0 - a1) - 1.0) / 3.0
    w0 = 1.0 - (1.0 - a1) / (1.0 - c)
    ring = count - 1
    weights = math.pi * np.array([w0] + [(1.0 - w0) / ring] * ring)
    return ConeSet(ring_directions(count, c), a, weights)


#: the opacity read is clamped below 1 so that its optical depth stays finite (vct_trace.glsl's VCT_MAX_ALPHA)
MAX_ALPHA = 1.0 - 1e-6


def step_transmittance(alphas: np.ndarray, d: np.ndarray, ds: float, voxel: float) -> float:
    """Transmittance of a step ds along unit d through a texel of edge `voxel` whose faces (the ones a cone
    along d reads, one per axis) have opacities `alphas` (3,). A face's alpha is the opacity of one texel's
    length along its axis (its surfaces' coverage), so Beer-Lambert gives tau_a = -ln(1 - alpha_a) / voxel per
    length; along d a surface of normal e_a shows |d_a| of its area, so T = prod_a (1 - alpha_a)^(|d_a| ds / voxel):
    a layer of normal e_a crossed at any angle (over vs / |d_a|) keeps its optical depth -ln(1 - alpha_a). Half
    a texel counts half its optical depth."""
    d = np.asarray(d, dtype=np.float64)
    tau = -np.log(1.0 - np.minimum(np.asarray(alphas, dtype=np.float64), MAX_ALPHA))
    return float(math.exp(-float(np.abs(d) @ tau) * ds / voxel))


def tangent_frame(n: np.ndarray) -> np.ndarray:
    """(3, 3) rows t, b, n: the frame vct_trace.glsl builds (the same helper-axis rule)."""
    n = np.asarray(n, dtype=np.float64)
    n = n / np.linalg.norm(n)
    helper = np.array([0.0, 1.0, 0.0]) if abs(n[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    t = np.cross(helper, n)
    t /= np.linalg.norm(t)
    return np.stack([t, np.cross(n, t), n])


def cap_directions(axes: np.ndarray, half_angle: float, count: int, rng: np.random.Generator) -> np.ndarray:
    """`count` directions uniform in solid angle over the cap of `half_angle` about each unit axis (K, 3):
    (K, count, 3), in each axis's `tangent_frame`. cos(theta) uniform in [cos a, 1] is uniform in solid angle."""
    k = len(axes)
    cz = 1.0 - rng.random((k, count)) * (1.0 - math.cos(half_angle))
    sz = np.sqrt(np.maximum(1.0 - cz * cz, 0.0))
    phi = 2.0 * math.pi * rng.random((k, count))
    local = np.stack([sz * np.cos(phi), sz * np.sin(phi), cz], -1)  # (K, count, 3)
    frames = np.array([tangent_frame(a) for a in axes])  # (K, 3, 3), rows t, b, n
    return np.einsum("kcj,kjd->kcd", local, frames)


def glossy_half_angle(exponent: float) -> float:
    """The glossy cone's half-angle (radians): 2 pi (1 - cos a) = 2 pi / (N + 1), i.e. cos a = N / (N + 1)."""
    a = math.degrees(math.acos(max(0.0, min(1.0, exponent / (exponent + 1.0)))))
    lo, hi = GLOSSY_HALF_ANGLE_RANGE
    return math.radians(min(max(a, lo), hi))


def cap_mean_cos(tan_half: float) -> float:
    """The mean cosine about its axis of directions uniform over a cap of half-angle a (tan a = `tan_half`):
    (1 + cos a) / 2 (uniform over the cap is uniform in cos on [cos a, 1])."""
    return 0.5 * (1.0 + 1.0 / math.sqrt(1.0 + tan_half * tan_half))


def broadened_exponent(exponent: float, spread_mean_cos: float) -> float:
    """The Phong exponent of the normalised Phong lobe of exponent N convolved with a spread of directions of
    mean cosine `spread_mean_cos` (vct_trace.glsl's vct_broadened_exponent mirrors it, with the derivation):
    zonal convolution on the sphere multiplies the first Legendre coefficients (Funk-Hecke), so the lobe's
    (N + 1) / (N + 2) times the spread's is the mean cosine mu of the two together, and the Phong lobe of mean
    cosine mu has N' = (2 mu - 1) / (1 - mu); 0 where mu <= 1/2 (broader than the cosine lobe)."""
    mu = (exponent + 1.0) / (exponent + 2.0) * spread_mean_cos
    return 0.0 if mu <= 0.5 else (2.0 * mu - 1.0) / (1.0 - mu)


#: midpoint samples of the lobe's polar CDF in `lobe_above_horizon` (vct_trace.glsl's VCT_HORIZON_SAMPLES)
HORIZON_SAMPLES = 32


#: the largest share of the Phong lobe beyond the horizon taken as none (lobe_above_horizon)
HORIZON_EXACT_TAIL = 1e-4


def lobe_above_horizon(cos_r: float, exponent: float, samples: int = HORIZON_SAMPLES) -> float:
    """The share of the normalised Phong lobe (N + 1) / (2 pi) (r . l)^N about r that lies above the surface
    (n . l > 0), for n . r = cos_r; vct_trace.glsl's vct_lobe_above mirrors it.

    The reference's Phong BSDF (groundtruth/pathtracer/paper_bsdf.py) gives the lobe's directions below the
    horizon weight 0, so a surface reflects only this share of what the whole lobe sees; it matters where r
    grazes the surface (1/2 at n . r = 0 for any N). With l at angle alpha from r and azimuth phi about it
    (phi = 0 toward n), n . l = s cos(alpha) + c sin(alpha) cos(phi), s = n . r, c = sqrt(1 - s^2): above
    where cos(phi) > t = -s cos(alpha) / (c sin(alpha)), a share g = acos(clamp(t, -1, 1)) / pi of the
    azimuths. The lobe's polar CDF is cos(alpha) = xi^(1 / (N + 1)) (uniform xi, the BSDF's own sampling), so
    the share is the mean of g over xi, taken at `samples` midpoints.

    Far from the horizon the share is 1 (or 0) to within HORIZON_EXACT_TAIL, without the sum: every direction
    below the horizon is at least asin(|s|) from r, and the lobe's mass beyond an angle theta from r is
    cos(theta)^(N + 1) (the same CDF), so 1 - share <= (1 - s^2)^((N + 1) / 2) for s > 0 (share itself for
    s < 0). Most reads of a glossy surface lie there, which the deferred glossy read, six per sample, needs."""
    s = float(np.clip(cos_r, -1.0, 1.0))
    if (1.0 - s * s) ** (0.5 * (float(exponent) + 1.0)) < HORIZON_EXACT_TAIL:
        return 1.0 if s > 0.0 else 0.0
    c = math.sqrt(max(0.0, 1.0 - s * s))
    xi = (np.arange(samples) + 0.5) / samples
    cos_a = xi ** (1.0 / (float(exponent) + 1.0))
    sin_a = np.sqrt(np.maximum(0.0, 1.0 - cos_a * cos_a))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(c * sin_a > 0.0, -s * cos_a / (c * sin_a), -np.sign(s) * np.inf)
    return float(np.mean(np.arccos(np.clip(t, -1.0, 1.0)) / math.pi))


@dataclass(frozen=True)
class Cascades:
    """`count` nested cubic grids of `resolution`^3 voxels centred on `centre`; cascade c spans
    half_extent * 2^c on each side of the centre (cascade 0 the finest)."""

    centre: tuple[float, float, float]
    half_extent: float  # of the finest cascade
    resolution: int
    count: int

    @property
    def voxel_size(self) -> float:
        """Edge of a voxel of the finest cascade."""
        return 2.0 * self.half_extent / self.resolution

    def half_extent_of(self, c: int) -> float:
        return self.half_extent * 2.0 ** c

    @property
    def levels(self) -> int:
        """Mip levels of each cascade (resolution down to 1)."""
        return int(math.log2(self.resolution)) + 1

    def cascade_of(self, p: np.ndarray) -> int:
        """The finest cascade holding p (-1: outside them all). A point must lie half a voxel of that
        cascade inside its box (trilinear lookups stay inside)."""
        off = np.abs(np.asarray(p, dtype=np.float64) - np.asarray(self.centre)).max()
        for c in range(self.count):
            if off <= self.half_extent_of(c) * (1.0 - 1.0 / self.resolution):
                return c
        return -1

    def level_of(self, p: np.ndarray, diameter: float, mip_min: float = 0.0) -> tuple[int, float]:
        """The seed's level selection: the cone's diameter d at p gives lod = log2(d / h0) over the
        whole pyramid (voxel size h0 2^lod); the cascade is floor(lod) (a coarser cascade covers the
        same level), never finer than the finest one holding p; the mip inside it is lod - cascade.

        `mip_min` (the injection's bounce passes: 1) keeps the mip inside the cascade at or above it, since
        those passes rewrite level 0 of every cascade while their cones read: the cascade is then
        floor(lod - mip_min), so that the same texel size h0 2^lod comes from a finer cascade's mip where the
        seed's rule would take a coarser cascade's level 0; where p lies only in cascades too coarse for that,
        the read is coarser than lod (mip_min of the finest one holding p)."""
        lod = max(0.0, math.log2(max(diameter, 1e-30) / self.voxel_size))
        inside = self.cascade_of(p)
        if inside < 0:
            return -1, 0.0
        c = min(max(int(math.floor(lod - mip_min)), inside), self.count - 1)
        return c, min(max(lod - c, mip_min), float(self.levels - 1))

    def bytes_per_cascade(self, bytes_per_voxel: int) -> int:
        """One cascade's six faces with their full mip chains (1 + 1/8 + ... of the finest)."""
        voxels = sum((self.resolution >> m) ** 3 for m in range(self.levels))
        return voxels * bytes_per_voxel

    def single_texture_bytes(self, bytes_per_voxel: int) -> int:
        """A plain 3D texture with the finest voxel size over the outermost extent, mip chain included."""
        r = self.resolution << (self.count - 1)
        return sum((r >> m) ** 3 for m in range(int(math.log2(r)) + 1)) * bytes_per_voxel


def footprint_cap(height: float, normal: np.ndarray, voxel: float) -> float:
    """The coarsest lod (over the whole pyramid, texel h0 2^lod) whose lookup at `height` above the tangent
    plane of normal `normal` stays off that surface's own voxels (h0 = `voxel`; vct_trace.glsl).

    A trilinear, mip-linear lookup at lod reads the 2x2x2 texels around p at levels floor(lod) and
    ceil(lod); the coarser ones, of edge s = h0 2^ceil(lod), reach 1.5 s from p along each axis, which is
    1.5 s |n|_1 below p along n. The surface's own voxels (conservative: boxes crossing the plane) reach
    h0 |n|_1 above it. No overlap while height - 1.5 s |n|_1 >= h0 |n|_1: s <= (height / |n|_1 - h0) / 1.5,
    so lod <= floor(log2 of that over h0), never below 0 (the offsets clear level 0)."""
    n1 = float(np.abs(np.asarray(normal, dtype=np.float64)).sum())
    s_max = (height / n1 - voxel) / 1.5
    return float(math.floor(math.log2(max(s_max, voxel) / voxel)))


def max_cone_samples(resolution: int, cascades: int, step: float) -> int:
    """The most samples a cone can take before it leaves the outermost cascade (vct_trace.glsl's loop bound),
    so that no cone is cut short. A cone steps `step` times its footprint, which is at least a finest voxel
    h0 (a cone grazing a surface stays capped there, whichever cascade it crosses), so at least step h0; a
    straight line crosses the outermost cascade's box over at most its diagonal,
    2 sqrt(3) (resolution / 2) h0 2^(C - 1). So at most sqrt(3) resolution 2^(C - 1) / step + 1 samples lie
    inside, plus the last one clamped to the boundary."""
    return math.ceil(math.sqrt(3.0) * resolution * 2 ** (cascades - 1) / step) + 2


def sample_lod(t: float, tan_half: float, height: float, normal: np.ndarray, voxel: float,
               lod_min: float = 0.0) -> tuple[float, float]:
    """(lod read, footprint diameter) of a cone sample at distance t along a cone of tan(half-angle)
    `tan_half`, `height` above the tangent plane of the surface it leaves (normal `normal`): the cone's
    diameter 2 t tan_half (at least a finest voxel) gives lod = log2(diameter / h0), capped by
    `footprint_cap`; `lod_min` raises the level read (the injection's), not the footprint (the step)."""
    cone = math.log2(max(2.0 * t * tan_half, voxel) / voxel)
    lod = min(cone, footprint_cap(height, normal, voxel))
    return max(lod, lod_min), voxel * 2.0 ** lod


def cascades_for(bounds_min: np.ndarray, bounds_max: np.ndarray, resolution: int, count: int,
                 margin: float = 1.1) -> Cascades:
    """Cascades centred on the objects' bounding box, the outermost holding the box (times `margin`)."""
    lo, hi = np.asarray(bounds_min, dtype=np.float64), np.asarray(bounds_max, dtype=np.float64)
    centre = (lo + hi) / 2.0
    outer = 0.5 * float((hi - lo).max()) * margin
    outer = max(outer, 1e-3)
    return Cascades(tuple(float(x) for x in centre), outer / 2.0 ** (count - 1), resolution, count)


INT32_MAX = 2 ** 31 - 1


def sum_scale(default: float, triangles: int, largest: float) -> float:
    """The fixed-point scale of one of the voxeliser's int32 sums (vct_voxelize.comp adds round(value * scale)
    per triangle and voxel): `default`, or where every one of the scene's `triangles` landing in one voxel, each
    adding `largest` * default, could pass 2^31 - 1, the largest power of two that cannot (a mesh of 40,000
    triangles of Phong exponent 4096 crowded into one voxel passed it at the exponent's default 16). The averages
    the injection divides out are the same for any scale, to the rounding of one step 1 / scale."""
    if triangles <= 0 or largest <= 0.0 or triangles * largest * default <= INT32_MAX:
        return default
    return 2.0 ** math.floor(math.log2(INT32_MAX / (triangles * largest)))


#: the largest radiance the faces (RGBA16F) are let to hold: 2^14, four times under half float's largest value
#: 65504, whose full precision (11 significant bits) reaches down to 2^-14
FACE_RADIANCE_MAX = 2.0 ** 14


def radiance_scale(peak: float) -> float:
    """What the faces' radiance is multiplied by when it is stored (and divided by when a cone reads it), for
    radiance at most `peak`: 1 where peak <= FACE_RADIANCE_MAX (nothing changes), else the power of two that
    brings peak under it. A face holds (1 - F) kd / pi (E V_d + E_b) + F ks H (L_g V_g + L_b); E <= pi L_max and
    L_g <= L_max for the environment's brightest radiance L_max, and each bounce adds at most an albedo (<= 1)
    times that, so peak = L_max max(kd + ks) bounces bounds it (`VoxelScene`). Half float would turn a 1e6 sun's
    glossy reflection into its largest value (llvmpipe) or infinity; a power of two scales exactly both ways,
    and the 2^28 between half float's smallest normal and FACE_RADIANCE_MAX keeps a sky 1e6 times dimmer than
    the sun at full precision."""
    if not math.isfinite(peak) or peak < 0.0:
        raise ValueError(f"radiance_scale: the faces' peak radiance must be finite and >= 0, got {peak}")
    if peak <= FACE_RADIANCE_MAX:
        return 1.0
    return 2.0 ** (math.log2(FACE_RADIANCE_MAX) - math.ceil(math.log2(peak)))


#: a mip pair at most this fraction of the opposite face's pair is a surface's back (vct_mip.comp's MIP_BACK_RATIO)
MIP_BACK_RATIO = 1e-3


def _halves(v: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """The even and the odd children of v along `axis`."""
    return np.take(v, range(0, v.shape[axis], 2), axis=axis), np.take(v, range(1, v.shape[axis], 2), axis=axis)


def anisotropic_mip(faces: np.ndarray) -> np.ndarray:
    """One level of the six-face mip (vct_mip.comp): faces (6, R, R, R, 4) indexed [face, x, y, z, rgba] with rgb
    premultiplied by alpha -> (6, R/2, R/2, R/2, 4). Face f (what leaves toward axis direction s e_a): along axis a
    the child nearer the viewer (on the s side) is in front: pair = c_front + (1 - a_front) c_back, alpha likewise;
    the texel's alpha is the mean of its four pairs'. Its radiance is normalised by the opacity of the pairs that
    are not a surface's back, rgb = alpha (sum_p rgb_p) / (sum_p' alpha_p'): a pair is a back where it is black
    (brightest channel at most MIP_BACK_RATIO of the other's) while the same two children composited the other way,
    in the opposite face, are lit; where no pair shows a front the plain mean stays (0 for a thin wall's dark
    side)."""
    faces = np.asarray(faces, dtype=np.float64)
    out = []
    for f, direction in enumerate(FACES):
        axis = int(np.flatnonzero(direction)[0])
        sign = direction[axis]

        lo, hi = _halves(faces[f], axis)
        front, back = (hi, lo) if sign > 0 else (lo, hi)
        pair = front + (1.0 - front[..., 3:4]) * back
        olo, ohi = _halves(faces[f ^ 1], axis)  # the opposite face: its front is this pair's back child
        ofront, oback = (olo, ohi) if sign > 0 else (ohi, olo)
        other = (ofront[..., :3] + (1.0 - ofront[..., 3:4]) * oback[..., :3]).max(-1)
        is_back = (other > 0.0) & (pair[..., :3].max(-1) <= MIP_BACK_RATIO * other)
        front_alpha = np.where(is_back, 0.0, pair[..., 3])
        # sums over the 2x2 pairs across the other two axes
        for a in (x for x in range(3) if x != axis):
            pair = sum(_halves(pair, a))
            front_alpha = sum(_halves(front_alpha, a))
        texel = 0.25 * pair
        lit = (front_alpha > 1e-6)[..., None]
        scale = texel[..., 3:4] / np.where(lit, front_alpha[..., None], 1.0)
        texel[..., :3] = np.where(lit, pair[..., :3] * scale, texel[..., :3])
        out.append(texel)
    return np.stack(out)


def _front_to_back(values: np.ndarray, alphas: np.ndarray, f: int) -> np.ndarray:
    """Face f's (direction s e_a) 2x2x2 children of `values` (R, R, R, K) composited as its mips composite them:
    along axis a the child on the s side in front, v_front a_front + v_back (1 - a_front) a_back, the four
    pairs summed -> (R/2, R/2, R/2, K)."""
    direction = FACES[f]
    axis = int(np.flatnonzero(direction)[0])
    lo_v, hi_v = _halves(values, axis)
    lo_a, hi_a = _halves(alphas, axis)
    (fv, fa), (bv, ba) = ((hi_v, hi_a), (lo_v, lo_a)) if direction[axis] > 0 else ((lo_v, lo_a), (hi_v, hi_a))
    pair = fa[..., None] * fv + ((1.0 - fa) * ba)[..., None] * bv
    for a in (x for x in range(3) if x != axis):
        pair = sum(_halves(pair, a))
    return pair


def normal_mip(normals: np.ndarray, alphas: np.ndarray) -> np.ndarray:
    """One level of the face normals' mip (vct_normal_mip.comp): normals (6, R, R, R, 3) indexed [face, x, y, z,
    xyz], unit vectors or 0 where no surface faces the face's direction, and the faces' opacities alphas
    (6, R, R, R) -> (6, R/2, R/2, R/2, 3). Face f (direction s e_a): along axis a the child on the s side is in
    front, m = a_front n_front + (1 - a_front) a_back n_back (a child with no normal still hides what is behind
    it), summed over the four pairs and normalised; 0 where the sum is 0."""
    normals = np.asarray(normals, dtype=np.float64)
    alphas = np.clip(np.asarray(alphas, dtype=np.float64), 0.0, 1.0)
    out = []
    for f in range(len(FACES)):
        pair = _front_to_back(normals[f], alphas[f], f)
        length = np.linalg.norm(pair, axis=-1, keepdims=True)
        out.append(np.where(length > 1e-6, pair / np.maximum(length, 1e-300), 0.0))
    return np.stack(out)


def normal_mean_length_mip(normals: np.ndarray, mean_lengths: np.ndarray, alphas: np.ndarray) -> np.ndarray:
    """One level of the face normals' spread (vct_normal_mip.comp, stored as vct_normal_bytes.glsl says): the
    mean cosine l of a face's surfaces' unit normals about its stored normal (the mean's length at level 0; 1 for
    one plane). From the children's normals (6, R, R, R, 3) (0: none), their mean cosines (6, R, R, R) and the
    faces' opacities: the children's means l n / |n| composited as `normal_mip` composites the normals, projected
    on `normal_mip`'s normal, over the same composite of the weights of the children that hold a normal
    -> (6, R/2, R/2, R/2), clamped to [0, 1]; 1 where none does. A plane's texels keep 1 whatever their
    opacities; two opaque children side by side with unit normals n1 and n2 give |n1 + n2| / 2."""
    normals = np.asarray(normals, dtype=np.float64)
    alphas = np.clip(np.asarray(alphas, dtype=np.float64), 0.0, 1.0)
    length = np.linalg.norm(normals, axis=-1, keepdims=True)
    held = length > 1e-6
    means = np.where(held, normals / np.maximum(length, 1e-300), 0.0) * np.asarray(mean_lengths, np.float64)[..., None]
    stored = normal_mip(normals, alphas)
    out = []
    for f in range(len(FACES)):
        mean = _front_to_back(means[f], alphas[f], f)
        weight = _front_to_back(held[f].astype(np.float64), alphas[f], f)[..., 0]
        ok = (weight > 0.0) & (np.linalg.norm(stored[f], axis=-1) > 0.0)
        cosine = (mean * stored[f]).sum(-1) / np.where(ok, weight, 1.0)
        out.append(np.where(ok, np.clip(cosine, 0.0, 1.0), 1.0))
    return np.stack(out)


def reflection_spread_mean_cos(mean_length: float) -> float:
    """The mean cosine, about the mirror of v in the surfaces' mean normal, of the mirrors of v in their own unit
    normals, for normals of mean cosine `mean_length` about their mean (vct_trace.glsl's
    vct_reflection_spread_mean_cos mirrors it, with the derivation): max(2 l^2 - 1, 0), the most spread that l
    allows (Jensen)."""
    return max(2.0 * mean_length * mean_length - 1.0, 0.0)


def read_direction(faces_at_voxel: np.ndarray, d: np.ndarray) -> np.ndarray:
    """What a cone travelling along unit d reads from one voxel's six faces (6, 4): the faces pointing
    against d, weighted by d's squared components (they sum to 1)."""
    d = np.asarray(d, dtype=np.float64)
    w = d * d
    out = np.zeros(4)
    for a in range(3):
        f = 2 * a + (1 if d[a] > 0 else 0)  # travelling +x: we see what leaves toward -x
        out += w[a] * faces_at_voxel[f]
    return out


def surface_voxel_bound(radius: float, voxel: float) -> float:
    """The number of voxels a sphere's surface can touch is about its area over a voxel face, times the
    shell thickness in voxels a surface can cross (sqrt(3): a voxel's diagonal): 4 pi r^2 / h^2 * sqrt 3,
    plus the shell's curvature term; used as the upper bound of a voxelised sphere's occupied count."""
    return 4.0 * math.pi * radius ** 2 / voxel ** 2 * math.sqrt(3.0) + 8.0 * math.pi * radius / voxel


def cap_visibility(radius: float, height: float) -> float:
    """Cosine-weighted visibility of the sky from a point on a plane straight below a sphere of `radius`
    whose centre is at `height`: the sphere blocks a cap of half-angle b with sin b = r / h, whose share of
    the cosine lobe is sin^2 b, so V = 1 - (r / h)^2."""
    return 1.0 - (radius / height) ** 2


def reduced_faces(faces: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A cube's faces (6, s, s, 3) as `size`^2-texel faces (s a multiple of `size`): (directions (n, 3), solid
    angles (n,), mean radiance (n, 3)), each texel's radiance the solid-angle-weighted mean of the texels it
    holds."""
    s = faces.shape[1]
    k = s // size
    if k * size != s:
        raise ValueError(f"a cube of {s} texels a face does not reduce to {size}")
    omega = cubemap.texel_solid_angles(s)
    weighted = (faces * omega[..., None]).reshape(6, size, k, size, k, 3).sum((2, 4)).reshape(-1, 3)
    w = np.broadcast_to(omega, faces.shape[:3]).reshape(6, size, k, size, k).sum((2, 4)).reshape(-1)
    return cubemap.texel_directions(size).reshape(-1, 3), w, weighted / w[:, None]


def lobe_integrals(faces: np.ndarray, axes: np.ndarray, exponent: float, size: int = 64) -> np.ndarray:
    """(n, 3) the normalised Phong lobe's integral of a cube environment, (N + 1) / (2 pi) int L(w)
    max(r . w, 0)^N dw, about each axis r (n, 3), by quadrature in float64 over the cube `faces` reduced to `size`
    texels a face: sum_k L_k W_k (r . d_k)^N / sum_k W_k (r . d_k)^N over the texels k in front of r (d_k their
    centres' directions, W_k their solid angles; normalised by the same sum, exact for a constant environment).
    The reference the broad-lobe table (lobe_table.py) is measured against, at a finer source than the table's."""
    dirs, w, radiance = reduced_faces(faces, size)
    axes = np.asarray(axes, dtype=np.float64)
    out = np.empty((len(axes), 3))
    for i in range(0, len(axes), 256):  # (256, 6 size^2) at a time
        c = axes[i:i + 256] @ dirs.T
        lobe = np.where(c > 0.0, np.maximum(c, 0.0) ** exponent, 0.0) * w
        out[i:i + 256] = (lobe @ radiance) / lobe.sum(axis=1, keepdims=True)
    return out
