"""Voxel cone tracing's bounce taken apart against ray casts: the cones' read, their quadrature, the injection.

    .venv/bin/python benchmarks/vct_cone_gather.py [--scene cornell-open] [--resolutions 32,64,128]
                                                   [--points 48] [--rays 512] [--seed 0] [--uniform]
                                                   [--bands 0] [--set KEY=VALUE ...]

A point's one bounce is kd / pi times the irradiance its six diffuse cones gather, sum_k w_k L_k, of the radiance
the voxels hold. Three factors stand between that and the exact bounce, each measured here against a ray cast of
the scene's triangles (Embree) at points sampled on every object (area-weighted, one cascade):

- the read: each cone traced as the shading traces it (`VoxelScene.trace_cone`, from the origin offset along the
  normal) against the exact cone integral of the voxels' own radiance, the mean over the cone's directions
  (uniform in solid angle over its cap) of the voxels' radiance where each ray from the surface point first meets
  a surface (0 where it escapes or meets a one-sided surface's back); and its opacity against the share of
  directions that meet a surface;
- the quadrature: the exact cone integrals weighted as the cones are, sum_k w_k L_k, against the exact
  irradiance of the same radiance over the whole hemisphere (cosine-weighted rays): what six cones of 33.6° make
  of the hemisphere even where each reads its own directions exactly;
- the injection: the voxels' radiance at the point against the exactly shadowed direct light under the same SH9
  environment, kd / pi int V L cos (V ray cast, L the SH9 radiance, whose cosine integral is the injection's
  E(n)), and against kd / pi E(n) V, the injection's form with the exact visibility; beside it the shading's own
  cones' visibility (`VoxelScene.probe`) over the exact one. Under a constant environment
  (`--set environment.map=builtin:constant`) the injected radiance is kd L V_d, so the injection's ratio is its
  V_d over the exact V.

Each figure is a ratio of sums over the points, with its standard error (a bootstrap over the points); the row
"all" weights each point by its object's area and albedo (the bounce's power), the row "seen" also by the pixels
it covers in the scene's camera (`camera_weights`), as an image's mean weighs it. Where the factors' errors differ
over the surfaces, an image's ratio is their product over what the camera sees, and a point's bounce carries the
injection of the surfaces it sees, not its own: the closing line multiplies the seen points' read × quadrature by
the injection as they gather it and by SH9's error against the map itself (`gathered_direct`), which together
stand for an image's bounce over the path tracer's. `--uniform` sets every lit face to radiance 1 (the mips
rebuilt): the read and the quadrature then measure geometry alone. `--bands N` adds VCT's gather over the exact
irradiance in N bands of height (y), which shows where over the surfaces the read errs: inside bowl-diffuse the
exact one is the same at every point of the hemisphere (two points of a sphere's inside see each other along a
chord at equal angles to both normals, so the form factor's kernel is 1 / (4 pi R^2) for every pair), so every band
of its inside should read the same.

Diffuse scenes only: the radiance at a hit is the voxel's face toward the surface's normal, which is the
surface's radiance toward every direction only where it is diffuse (`--set "objects.6.material={type =
'diffuse', kd = [0, 0, 0]}"` turns cornell-open's Phong sphere into a black blocker). bowl-diffuse is one
object, its inside and outside together. The diffuse cones' caps stay above the surface's plane
(`vct_math.cone_set`: at most 83.4° from the normal for six cones); the seed's ring at 60° reached 2.2 % of its
directions below it, where on a curved surface the ray cast meets the surface's own back (a hit of radiance 0)
and VCT's offset cone does not.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

import scenes
from realtime.engine import transfer_rays
from realtime.engine.context import get_context
from realtime.engine.environment_maps import filled_store
from realtime.techniques.vct import vct_math
from realtime.techniques.vct.vct import NORMAL_OFFSET_VOXELS, START_OFFSET_VOXELS, VoxelScene
from scenes.environment import envmap
from scenes.environment.shbasis import sh9
from scenes.model.camera import Camera
from scenes.model.scene import Scene, SceneObject
from scenes.storage.errors import SceneError

#: the face directions in the voxels' order (+X, -X, +Y, -Y, +Z, -Z)
FACE_AXES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=np.float64)
CONES = 6
#: bootstrap resamples of the points for the standard errors
RESAMPLES = 200
#: rays a seen point gathers its bounce over, and rays each of their hits takes its direct light over
#: (`gathered_direct`: their product a point, so fewer than `--rays`)
GATHER_RAYS = 64


@dataclass(frozen=True)
class Triangles:
    """The scene's triangles: vertices (F, 3, 3), geometric normals (F, 3) on the side the vertex normals give,
    the object of each (F,), and whether that object is two-sided (per object)."""
    vertices: np.ndarray
    normals: np.ndarray
    object_id: np.ndarray
    two_sided: np.ndarray

    def areas(self) -> np.ndarray:
        """Each triangle's area (F,)."""
        v = self.vertices
        return 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)


def scene_triangles(objects: Sequence[SceneObject]) -> Triangles:
    """The objects' meshes as one triangle list, each triangle's geometric normal turned to its vertex normals'
    side (a one-sided surface's front)."""
    verts, norms, ids = [], [], []
    for i, obj in enumerate(objects):
        m = obj.mesh
        v = m.positions.astype(np.float64)[m.indices]
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        side = np.sign(np.einsum("fj,fj->f", n, m.normals.astype(np.float64)[m.indices].sum(1)))
        verts.append(v)
        norms.append(n * np.where(side == 0.0, 1.0, side)[:, None])
        ids.append(np.full(len(v), i, dtype=np.int32))
    two_sided = np.array([bool(obj.material.two_sided) for obj in objects])
    return Triangles(np.concatenate(verts), np.concatenate(norms), np.concatenate(ids), two_sided)


def scene_intersector(tris: Triangles) -> Any:
    """Embree's intersector of the triangles (trimesh's RayMeshIntersector), built as they are."""
    return transfer_rays.intersector(tris.vertices.reshape(-1, 3),
                                     np.arange(len(tris.vertices) * 3).reshape(-1, 3), "the cone check")


def ray_offset(tris: Triangles) -> float:
    """How far rays start from their surface: 1e-4 of the triangles' bounding-box diagonal."""
    return 1e-4 * float(np.linalg.norm(np.ptp(tris.vertices.reshape(-1, 3), axis=0)))


def camera_weights(ray: Any, points: np.ndarray, normals: np.ndarray, camera: Camera, eps: float) -> np.ndarray:
    """Each point's share of an image's pixels per unit of its area (P,): a surface element dA at distance d, its
    normal at angle theta from the camera, subtends cos(theta) dA / d^2, and a pixel at angle phi off the view axis
    subtends (pixel area / focal length^2) cos^3(phi) (its plane's distance grows as 1 / cos phi and it is seen
    obliquely by cos phi), so it covers cos(theta) / (d^2 cos^3(phi)) pixels up to a constant; 0 where the point
    lies outside the image (`Camera.project`), faces away from the camera or something lies between them."""
    to_camera = np.asarray(camera.origin, dtype=np.float64) - points
    d = np.linalg.norm(to_camera, axis=1)
    v = to_camera / d[:, None]
    cos_theta = np.einsum("pj,pj->p", normals, v)
    cos_phi = -v @ camera.basis()[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        col, row = np.moveaxis(camera.project(points), -1, 0)  # the image's own pixel convention
    in_view = (cos_phi > 0.0) & (col >= 0.0) & (col <= camera.width) & (row >= 0.0) & (row <= camera.height)
    front = np.flatnonzero((cos_theta > 0.0) & in_view)
    if front.size == 0:
        return np.zeros(len(points))
    seen = np.zeros(len(points), dtype=bool)
    seen[front] = True
    loc, index_ray, _ = ray.intersects_location(points[front] + eps * v[front], v[front], multiple_hits=False)
    hit = front[index_ray]
    seen[hit[np.linalg.norm(loc - points[hit], axis=1) < d[hit] - eps]] = False  # met before the camera
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(seen, cos_theta / (d ** 2 * cos_phi ** 3), 0.0)


def height_bands(heights: np.ndarray, count: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """`count` equal bands of height over the range of `heights`, lowest first: (their count + 1 edges, a mask
    per band; the top band holds its upper bound)."""
    edges = np.linspace(float(heights.min()), float(heights.max()), count + 1)
    band = np.clip(np.searchsorted(edges, heights, side="right") - 1, 0, count - 1)
    return edges, [band == b for b in range(count)]


def level0_faces(vs: VoxelScene) -> np.ndarray:
    """Level 0's six faces (6, R, R, R, 4) of the (one) cascade, rgb in the scene's own units as the cones return
    them (the faces store radiance times `radiance_scale`)."""
    faces = vs.read_faces(0)[:, 0]
    faces[..., :3] /= vs.radiance_scale
    return faces


def grid_lower_corner(vs: VoxelScene) -> np.ndarray:
    """The lower corner of the voxels' (one) cascade."""
    return np.asarray(vs.grid.centre, dtype=np.float64) - vs.grid.half_extent


def surface_points(tris: Triangles, per_object: int, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """`per_object` points on each object, area-weighted over its triangles and uniform inside each: (points,
    the triangles' normals, object ids)."""
    pts, nrm, ids = [], [], []
    area = tris.areas()
    for i in np.unique(tris.object_id):
        idx = np.flatnonzero(tris.object_id == i)
        pick = rng.choice(idx, size=per_object, p=area[idx] / area[idx].sum())
        u, v = rng.random(per_object), rng.random(per_object)
        flip = u + v > 1.0
        u, v = np.where(flip, 1.0 - u, u), np.where(flip, 1.0 - v, v)
        t = tris.vertices[pick]
        pts.append(t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0]))
        nrm.append(tris.normals[pick])
        ids.append(np.full(per_object, i))
    return np.concatenate(pts), np.concatenate(nrm), np.concatenate(ids)


def frames_of(axes: np.ndarray) -> np.ndarray:
    """The tangent frames (K, 3, 3), rows t, b, n, of unit axes (K, 3), as the shader's vct_frame builds them."""
    return np.array([vct_math.tangent_frame(a) for a in axes])


def cosine_directions(normals: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """`count` directions with density cos / pi about each unit normal (P, 3): (P, count, 3), the PRT
    precomputation's rays (transfer_rays.directions: a Fibonacci lattice, Cranley-Patterson rotated per point)."""
    return transfer_rays.directions(normals, rng.random((len(normals), 2)), transfer_rays.lattice(count))


def voxel_radiance(faces: np.ndarray, lo: np.ndarray, voxel: float, points: np.ndarray,
                   normals: np.ndarray) -> np.ndarray:
    """The grey radiance the voxels hold for surfaces at `points` with `normals` (both (M, 3)): level 0's face
    toward the normal's largest component (faces (6, R, R, R, 4), premultiplied by the coverage), radiance =
    mean(rgb) / coverage, in the voxel holding the point; where that voxel does not hold the face (a point the
    conservative voxeliser left to a neighbour, a hair past a voxel's boundary), the most covered of its 26
    neighbours; 0 where none does."""
    res = faces.shape[1]
    f = np.argmax(normals @ FACE_AXES.T, axis=1)
    base = np.floor((points - lo) / voxel).astype(np.int64)

    def texel(offset: tuple[int, int, int]) -> np.ndarray:
        j = np.clip(base + offset, 0, res - 1)
        return faces[f, j[:, 0], j[:, 1], j[:, 2]]

    own = texel((0, 0, 0))
    best_a, best_rgb = own[:, 3].copy(), own[:, :3].mean(1)
    empty = best_a <= 1e-6
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                t = texel((dx, dy, dz))
                better = empty & (t[:, 3] > best_a)
                best_a = np.where(better, t[:, 3], best_a)
                best_rgb = np.where(better, t[:, :3].mean(1), best_rgb)
    return np.where(best_a > 1e-6, best_rgb / np.maximum(best_a, 1e-6), 0.0)


def first_hits(ray: Any, tris: Triangles, origins: np.ndarray,
               directions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where rays (origins, directions: (M, 3)) cast with the intersector `ray` first meet a surface: (the hits'
    locations, the index of each hit's ray, its triangle, the triangle's normal on the side the ray meets, whether
    that side sends light). A one-sided surface met from behind blocks and sends nothing; a two-sided one sends
    from the side the ray meets."""
    loc, index_ray, index_tri = ray.intersects_location(origins, directions, multiple_hits=False)
    n = tris.normals[index_tri]
    facing = np.einsum("mj,mj->m", n, directions[index_ray]) < 0.0
    two = tris.two_sided[tris.object_id[index_tri]]
    return loc, index_ray, index_tri, np.where((~facing & two)[:, None], -n, n), facing | two


def hit_radiance(ray: Any, tris: Triangles, faces: np.ndarray, lo: np.ndarray, voxel: float, origins: np.ndarray,
                 directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rays (origins, directions: (M, 3)) cast with the intersector `ray`: (the voxels' radiance where each first
    meets a surface, 0 where it escapes or meets a side that sends nothing (`first_hits`); whether it met one)."""
    loc, index_ray, _, n, sends = first_hits(ray, tris, origins, directions)
    radiance = np.zeros(len(origins))
    hit = np.zeros(len(origins), dtype=bool)
    hit[index_ray] = True
    radiance[index_ray] = np.where(sends, voxel_radiance(faces, lo, voxel, loc, n), 0.0)
    return radiance, hit


def exact_cones(ray: Any, tris: Triangles, faces: np.ndarray, lo: np.ndarray, voxel: float, points: np.ndarray,
                directions: np.ndarray, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """The exact cone integrals of the voxels' radiance from points (K, 3) over each cone's directions
    (K, count, 3), rays starting eps along them: (mean radiance (K,), share of directions that meet a surface)."""
    k, count, _ = directions.shape
    d = directions.reshape(-1, 3)
    radiance, hit = hit_radiance(ray, tris, faces, lo, voxel, np.repeat(points, count, axis=0) + eps * d, d)
    return radiance.reshape(k, count).mean(1), hit.reshape(k, count).mean(1)


def exact_irradiance(ray: Any, tris: Triangles, faces: np.ndarray, lo: np.ndarray, voxel: float, points: np.ndarray,
                     normals: np.ndarray, count: int, eps: float, rng: np.random.Generator) -> np.ndarray:
    """The irradiance of the voxels' radiance over each point's whole hemisphere, int L cos = pi E[L] over
    cosine-weighted directions: (P,)."""
    d = cosine_directions(normals, count, rng).reshape(-1, 3)
    radiance, _ = hit_radiance(ray, tris, faces, lo, voxel, np.repeat(points, count, axis=0) + eps * d, d)
    return math.pi * radiance.reshape(len(points), count).mean(1)


def sh9_sky(coeffs: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """The environment's SH9 radiance (coeffs (9, 3)) along directions (..., 3), unclamped: the radiance whose
    cosine integral is the injection's E(n)."""
    return lambda d: sh9(d) @ coeffs


def map_sky(scene: Scene) -> Callable[[np.ndarray], np.ndarray]:
    """The environment map's own radiance along directions (..., 3), looked up as the path tracer looks it up
    (`envmap.lookup`, the map's rotation applied)."""
    env, turn = scene.environment.radiance(), scene.environment.rotation_deg
    return lambda d: envmap.lookup(env, d, turn)


def exact_direct(ray: Any, points: np.ndarray, normals: np.ndarray, albedo: np.ndarray,
                 sky: Callable[[np.ndarray], np.ndarray], count: int, eps: float,
                 rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A diffuse surface's direct radiance under the radiance `sky` (`sh9_sky`, `map_sky`), shadowed by the
    scene: kd / pi int V(w) L(w) cos dw = kd E[V L] over cosine-weighted directions, grey (the channels' mean);
    and the cosine-weighted visibility V = E[V]: ((P,), (P,)). albedo (P, 3)."""
    if len(points) == 0:
        return np.zeros(0), np.zeros(0)
    d = cosine_directions(normals, count, rng)
    o = np.repeat(points, count, axis=0) + eps * d.reshape(-1, 3)
    vis = transfer_rays.visible(ray, o, d.reshape(-1, 3)).reshape(len(points), count)
    direct = (albedo[:, None, :] * sky(d) * vis[..., None]).mean(1).mean(-1)
    return direct, vis.mean(1)


def gathered_direct(ray: Any, tris: Triangles, albedo: np.ndarray, faces: np.ndarray, lo: np.ndarray, voxel: float,
                    points: np.ndarray, normals: np.ndarray, skies: Sequence[Callable[[np.ndarray], np.ndarray]],
                    count: int, direct_count: int, eps: float,
                    rng: np.random.Generator) -> tuple[np.ndarray, list[np.ndarray]]:
    """The one bounce each point gathers, pi E[L(hit)] over `count` cosine-weighted rays (0 where a ray escapes or
    meets a one-sided surface's back), of two radiances at the hits: the voxels' injected radiance
    (`voxel_radiance`) and the exact direct light under each of `skies` (`exact_direct`, `direct_count` rays a hit;
    `albedo` (objects, 3)): (the injected's (P,), [each sky's (P,)]). Taken over the same rays, their ratio is the
    injection as the points gather it: the light of the surfaces they see, not their own."""
    p = len(points)
    if p == 0:
        return np.zeros(0), [np.zeros(0) for _ in skies]
    d = cosine_directions(normals, count, rng).reshape(-1, 3)
    loc, index_ray, index_tri, n, sends = first_hits(ray, tris, np.repeat(points, count, axis=0) + eps * d, d)
    loc, n, index_ray, index_tri = loc[sends], n[sends], index_ray[sends], index_tri[sends]
    injected = np.zeros(p * count)
    injected[index_ray] = voxel_radiance(faces, lo, voxel, loc, n)
    out = []
    for sky in skies:
        direct = np.zeros(p * count)
        direct[index_ray], _ = exact_direct(ray, loc + eps * n, n, albedo[tris.object_id[index_tri]], sky,
                                            direct_count, eps, rng)
        out.append(math.pi * direct.reshape(p, count).mean(1))
    return math.pi * injected.reshape(p, count).mean(1), out


def voxelise(scene: Scene, resolution: int) -> tuple[VoxelScene, np.ndarray, np.ndarray]:
    """The scene voxelised and injected at `resolution`^3 (one cascade, six cones, step 0.5, the scene's
    environment as SH9 from a 64^2 filter, as E10's probes do): (the voxels, which the caller releases, the SH9
    radiance coefficients (9, 3), the irradiance matrices M (3, 4, 4) the injection's E(n) = n^T M n uses)."""
    ctx = get_context()
    env = filled_store(ctx, scene)
    try:
        vs = VoxelScene(ctx, scene.objects, resolution, 1, CONES, 0.5)
        vs.update(None, env.sh_buffer)
        coeffs, irradiance = env.read_sh()
    finally:
        env.release()
    return vs, coeffs, irradiance


def light_uniformly(vs: VoxelScene) -> None:
    """Every lit face of level 0 set to radiance 1 (times its coverage, premultiplied, and the radiance scale),
    the mips rebuilt."""
    f = vs.read_faces(0)
    lit = f[..., :3].max(-1) > 0.0
    f[..., :3] = np.where(lit[..., None], vs.radiance_scale * f[..., 3:4], 0.0)
    vs.write_level0(f.astype("f4"), vs.read_normals(0), vs.read_normal_mean_lengths(0))
    vs.build_mips()


@dataclass
class ConeRows:
    """Per point (P) and cone: VCT's gathered grey radiance and opacity, the exact ones; the cone weights; per
    point the exact irradiance of the voxels' radiance, the injected and exact direct radiance, the injection's
    form with the exact visibility, the shading's own cones' irradiance and visibility, the exact visibility,
    each point's weight in the row "all" (its object's area over its points, times its albedo), the points, and
    where the camera sees them their weight in the row "seen" (`camera_weights` times the same) and the one bounce
    they gather of the injected radiance and of the exact direct light under SH9 and under the map
    (`gathered_direct`)."""
    object_id: np.ndarray  # (P,)
    vct_radiance: np.ndarray  # (P, CONES)
    vct_opacity: np.ndarray
    exact_radiance: np.ndarray
    exact_opacity: np.ndarray
    weights: np.ndarray  # (CONES,), sum pi
    exact_irradiance: np.ndarray  # (P,)
    injected: np.ndarray
    exact_direct: np.ndarray
    unshadowed_times_v: np.ndarray  # kd / pi E(n) V_exact
    probe_irradiance: np.ndarray  # the shading's own diffuse cones (VoxelScene.probe), grey
    probe_visibility: np.ndarray
    exact_visibility: np.ndarray
    power_weight: np.ndarray
    points: np.ndarray  # (P, 3), on the surfaces
    camera_weight: np.ndarray  # (P,), camera_weights in the scene's camera, times the point's area and albedo
    gathered_injected: np.ndarray  # (P,), gathered_direct where the camera sees the point, else 0
    gathered_sh9: np.ndarray
    gathered_map: np.ndarray


def gather(scene: Scene, resolution: int, per_object: int, rays: int, seed: int, uniform: bool = False) -> ConeRows:
    """Voxelise and inject the scene (`voxelise`; `uniform`: `light_uniformly`), then at every point trace and
    ray cast its six diffuse cones, cast its hemisphere and its exact direct light, and probe the shading's cones."""
    rng = np.random.default_rng(seed)
    tris = scene_triangles(scene.objects)
    points, normals, ids = surface_points(tris, per_object, rng)
    p = len(points)
    cones = vct_math.cone_set(CONES)
    axes = np.einsum("cj,pjd->pcd", cones.directions, frames_of(normals)).reshape(-1, 3)
    vs, coeffs, irradiance = voxelise(scene, resolution)
    try:
        if uniform:
            light_uniformly(vs)
        h = vs.grid.voxel_size
        lo = grid_lower_corner(vs)
        cone = vs.trace_cone(np.repeat(points + NORMAL_OFFSET_VOXELS * h * normals, CONES, 0), axes,
                             np.full(p * CONES, math.tan(cones.half_angle)),
                             np.full(p * CONES, START_OFFSET_VOXELS * h), np.repeat(points, CONES, 0),
                             np.repeat(normals, CONES, 0))
        probe = vs.probe(points, normals)
        faces = level0_faces(vs)
    finally:
        vs.release()
    ray = scene_intersector(tris)
    eps = ray_offset(tris)
    ex_l, ex_a = exact_cones(ray, tris, faces, lo, h, np.repeat(points, CONES, 0),
                             vct_math.cap_directions(axes, cones.half_angle, rays, rng), eps)
    hemisphere = exact_irradiance(ray, tris, faces, lo, h, points, normals, rays, eps, rng)
    albedo = np.array([scene.objects[i].material.kd for i in ids], dtype=np.float64)
    direct, v_exact = exact_direct(ray, points, normals, albedo, sh9_sky(coeffs), rays, eps, rng)
    n4 = np.c_[normals, np.ones(p)]
    e_sh = np.maximum(np.einsum("pi,cij,pj->pc", n4, irradiance, n4), 0.0)  # the injection's E(n), per channel
    area = np.bincount(tris.object_id, weights=tris.areas())
    power = area[ids] / np.bincount(ids)[ids] * albedo.mean(1)
    seen_weight = camera_weights(ray, points, normals, scene.camera, eps) * power
    seen = np.flatnonzero(seen_weight > 0.0)
    object_albedo = np.array([o.material.kd for o in scene.objects], dtype=np.float64)
    gathered = [np.zeros(p) for _ in range(3)]
    if not uniform:
        inj, (by_sh9, by_map) = gathered_direct(ray, tris, object_albedo, faces, lo, h, points[seen], normals[seen],
                                                [sh9_sky(coeffs), map_sky(scene)], GATHER_RAYS, GATHER_RAYS, eps,
                                                rng)
        for g, values in zip(gathered, (inj, by_sh9, by_map), strict=True):
            g[seen] = values
    return ConeRows(ids, cone[:, :3].mean(1).reshape(p, CONES), cone[:, 3].reshape(p, CONES),
                    ex_l.reshape(p, CONES), ex_a.reshape(p, CONES), cones.weights, hemisphere,
                    voxel_radiance(faces, lo, h, points, normals), direct,
                    (albedo / math.pi * e_sh).mean(1) * v_exact, probe[:, :3].mean(1), probe[:, 3], v_exact, power,
                    points, seen_weight, *gathered)


def ratio(a: np.ndarray, b: np.ndarray, w: np.ndarray | None = None) -> float:
    """sum(w a) / sum(w b) over the points (w = 1 when None); nan where the denominator is 0."""
    w = np.ones(len(a)) if w is None else w
    s = float(w @ b)
    return float(w @ a) / s if s > 0.0 else float("nan")


def with_error(a: np.ndarray, b: np.ndarray, w: np.ndarray, groups: np.ndarray, rng: np.random.Generator) -> str:
    """ratio(a, b, w) and its bootstrap standard error (the points resampled within each group), "r ± e"."""
    r = ratio(a, b, w)
    if not np.isfinite(r):
        return "-"
    members = [np.flatnonzero(groups == g) for g in np.unique(groups)]
    boot = []
    for _ in range(RESAMPLES):
        idx = np.concatenate([rng.choice(m, size=len(m)) for m in members])
        boot.append(ratio(a[idx], b[idx], w[idx]))
    return f"{r:.3f} ± {np.nanstd(boot):.3f}"


def summary(rows: ConeRows, names: list[str], injection: bool, seed: int = 0) -> list[str]:
    """The read's and the quadrature's table (one row per object and "all"), and where `injection` the
    injection's."""
    rng = np.random.default_rng(seed)
    groups = [(names[i], rows.object_id == i, np.ones(len(rows.object_id))) for i in np.unique(rows.object_id)]
    groups.append(("all", rows.object_id >= 0, rows.power_weight))
    if rows.camera_weight.any():
        groups.append(("seen", rows.camera_weight > 0.0, rows.camera_weight))
    e_vct = rows.vct_radiance @ rows.weights
    e_cones = rows.exact_radiance @ rows.weights
    out = ["| object | read: VCT / exact cones | quadrature: exact cones / hemisphere | VCT / hemisphere "
           "| L VCT / exact, cones 0-5 | opacity VCT / exact, cones 0-5 |", "|---|---|---|---|---|---|"]
    for name, m, w in groups:
        g = rows.object_id[m]
        per_l = " ".join(f"{ratio(rows.vct_radiance[m, k], rows.exact_radiance[m, k]):.2f}" for k in range(CONES))
        per_a = " ".join(f"{rows.vct_opacity[m, k].mean():.2f}/{rows.exact_opacity[m, k].mean():.2f}"
                         for k in range(CONES))
        out.append(f"| {name} | {with_error(e_vct[m], e_cones[m], w[m], g, rng)} "
                   f"| {with_error(e_cones[m], rows.exact_irradiance[m], w[m], g, rng)} "
                   f"| {with_error(e_vct[m], rows.exact_irradiance[m], w[m], g, rng)} | {per_l} | {per_a} |")
    if not injection:
        return out
    out += ["", "| object | injected / exact direct | injected / kd E(n) V / pi | V: shading's cones / exact |",
            "|---|---|---|---|"]
    for name, m, w in groups:
        g = rows.object_id[m]
        out.append(f"| {name} | {with_error(rows.injected[m], rows.exact_direct[m], w[m], g, rng)} "
                   f"| {with_error(rows.injected[m], rows.unshadowed_times_v[m], w[m], g, rng)} "
                   f"| {with_error(rows.probe_visibility[m], rows.exact_visibility[m], w[m], g, rng)} |")
    if rows.camera_weight.any():
        w = rows.camera_weight
        read = ratio(e_vct, rows.exact_irradiance, w)
        injected = ratio(rows.gathered_injected, rows.gathered_sh9, w)
        sky = ratio(rows.gathered_sh9, rows.gathered_map, w)
        out += ["", f"seen by the camera, each point's bounce as it gathers it (the light of the surfaces it sees): "
                    f"read x quadrature {read:.3f} x injection {injected:.3f} (the injected radiance over the exact "
                    f"direct light under SH9) x SH9 over the map {sky:.3f} = {read * injected * sky:.3f}, an image's "
                    "bounce over the path tracer's"]
    return out


def band_lines(rows: ConeRows, count: int) -> list[str]:
    """VCT's gather (the shading's own cones) over the exact irradiance of the voxels' radiance in `count` bands
    of height, over the points that gather any bounce (exact irradiance > 0: bowl-diffuse's outside gathers none),
    each band's points weighted alike, with the exact irradiance's mean (a table)."""
    gathers = rows.exact_irradiance > 0.0
    if not gathers.any():
        return ["no point gathers a bounce: no bands"]
    out = ["| height (y) | points | exact irradiance, mean | VCT / exact |", "|---|---|---|---|"]
    edges, bands = height_bands(rows.points[gathers, 1], count)
    for b, m in enumerate(bands):
        exact = rows.exact_irradiance[gathers][m]
        share = f"{rows.probe_irradiance[gathers][m].sum() / exact.sum():.3f}" if exact.sum() > 0.0 else "-"
        mean = f"{exact.mean():.4f}" if m.any() else "-"
        out.append(f"| {edges[b]:.3f} to {edges[b + 1]:.3f} | {int(m.sum())} | {mean} | {share} |")
    return out


def positive_ints(text: str) -> list[int]:
    """"32,64" -> [32, 64]; ValueError unless every item is a positive integer."""
    values = [int(t) for t in text.split(",")]
    if not values or min(values) <= 0:
        raise ValueError(text)
    return values


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="cornell-open")
    ap.add_argument("--resolutions", default="32,64,128")
    ap.add_argument("--points", type=int, default=48, help="points per object")
    ap.add_argument("--rays", type=int, default=512, help="rays per cone, per hemisphere and per direct light")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--uniform", action="store_true", help="every lit face at radiance 1: geometry alone")
    ap.add_argument("--bands", type=int, default=0, help="also VCT over exact by this many bands of height")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a scene override")
    a = ap.parse_args()
    try:
        resolutions = positive_ints(a.resolutions)
    except ValueError:
        ap.error(f"--resolutions {a.resolutions!r}: expected positive integers separated by commas")
    for flag, value in (("--points", a.points), ("--rays", a.rays)):
        if value <= 0:
            ap.error(f"{flag} {value}: must be positive")
    if a.bands < 0:
        ap.error(f"--bands {a.bands}: must be 0 or more")
    bad = [kv for kv in a.set if "=" not in kv]
    if bad:
        ap.error(f"--set {bad[0]!r}: expected KEY=VALUE")
    spec = a.scene if ":" in a.scene or a.scene.endswith(".toml") else f"builtin:{a.scene}"
    try:
        scene = scenes.load(spec).with_overrides(dict(kv.split("=", 1) for kv in a.set))
    except SceneError as exc:
        ap.error(str(exc))
    glossy = [i for i, o in enumerate(scene.objects) if o.material.type != "diffuse"]
    if glossy:
        i = glossy[0]
        ap.error(f"{spec}: objects.{i}.material.type = {scene.objects[i].material.type!r}: this check reads a "
                 f"diffuse surface's radiance (--set \"objects.{i}.material={{type = 'diffuse', kd = [0, 0, 0]}}\" "
                 "makes it a black blocker)")
    names = [f"{i} {o.shape}" for i, o in enumerate(scene.objects)]
    for res in resolutions:
        rows = gather(scene, res, a.points, a.rays, a.seed, a.uniform)
        lit = "every lit face at radiance 1" if a.uniform else scene.environment.map
        print(f"\n{spec} at {res}^3 ({a.points} points an object, {a.rays} rays a cone; {lit})")
        print("\n".join(summary(rows, names, injection=not a.uniform, seed=a.seed)), flush=True)
        if a.bands:
            print("\n" + "\n".join(band_lines(rows, a.bands)), flush=True)


if __name__ == "__main__":
    main()
