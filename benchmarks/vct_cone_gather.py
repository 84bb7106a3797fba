"""What each diffuse cone gathers of the voxels' own radiance, against the exact cone integral of that radiance.

    .venv/bin/python benchmarks/vct_cone_gather.py [--scene cornell-open] [--resolutions 32,64,128]
                                                   [--points 24] [--rays 512] [--seed 0] [--set KEY=VALUE ...]

VCT's bounce has two halves: the injection (the radiance the voxels hold) and the cone read (what a cone gathers
of it). This separates them. At points sampled on every object's surface (area-weighted, one cascade), each of
the six diffuse cones is traced as the shading pass traces it (`VoxelScene.trace_cone`, from the origin offset
along the normal), and its directions, uniform in solid angle over the cone's cap, are ray cast against the
scene's triangles (Embree) from the surface point itself: the exact cone integral of the voxels' radiance is the
mean over those directions of the injected radiance where each ray first meets a surface (0 where it escapes or
meets a one-sided surface's back), and the exact opacity the share of directions that meet a surface. Printed
per object and per cone (0 along the normal, 1-5 the ring): VCT's gathered radiance over the exact one, VCT's
opacity against the exact share, and per object the cosine-weighted sum over the cones, sum_k w_k L_k (the
irradiance the shading multiplies by the albedo), VCT's over the exact one. A read that matched the exact
integral would leave VCT's bounce error to the injection alone.

The injection's half: the voxels' radiance at each point over the exact direct light there, kd / pi int V L cos
with V ray cast and L the environment's SH9 radiance (the injection's own E(n) is that radiance's cosine
integral), and over kd / pi E(n) V_exact, the injection's form with the exact visibility (under a constant
environment, `--set environment.map=builtin:constant`, the two agree and the ratio is the injection's V_d over
the exact V).

Diffuse scenes only: the radiance at a hit is the voxel's face toward the surface's normal, which is the
surface's radiance toward every direction only where it is diffuse (`--set "objects.6.material={type =
'diffuse', kd = [0, 0, 0]}"` turns cornell-open's Phong sphere into a black blocker). bowl-diffuse is one
object, its inside and outside together.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import numpy as np

import scenes
from realtime.engine.context import get_context
from realtime.engine.environment_maps import environment_store
from realtime.engine.transfer_rays import intersector
from realtime.techniques.vct import vct_math
from realtime.techniques.vct.vct import NORMAL_OFFSET_VOXELS, START_OFFSET_VOXELS, VoxelScene
from scenes.environment.shbasis import sh9
from scenes.storage.errors import SceneError

#: the face directions in the voxels' order (+X, -X, +Y, -Y, +Z, -Z)
FACE_AXES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=np.float64)
CONES = 6


@dataclass(frozen=True)
class Triangles:
    """The scene's triangles: vertices (F, 3, 3), geometric normals (F, 3) on the side the vertex normals give,
    the object of each (F,), and whether that object is two-sided (per object)."""
    vertices: np.ndarray
    normals: np.ndarray
    object_id: np.ndarray
    two_sided: np.ndarray


def scene_triangles(objects) -> Triangles:
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


def scene_intersector(tris: Triangles):
    """Embree's intersector of the triangles, built as they are."""
    return intersector(tris.vertices.reshape(-1, 3), np.arange(len(tris.vertices) * 3).reshape(-1, 3),
                       "the cone check")


def ray_offset(tris: Triangles) -> float:
    """How far rays start from their surface: 1e-4 of the triangles' bounding-box diagonal."""
    return 1e-4 * float(np.linalg.norm(np.ptp(tris.vertices.reshape(-1, 3), axis=0)))


def grid_lower_corner(vs: VoxelScene) -> np.ndarray:
    """The lower corner of the voxels' (one) cascade."""
    return np.asarray(vs.grid.centre, dtype=np.float64) - vs.grid.half_extent


def surface_points(tris: Triangles, per_object: int, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """`per_object` points on each object, area-weighted over its triangles and uniform inside each: (points,
    the triangles' normals, object ids)."""
    pts, nrm, ids = [], [], []
    area = 0.5 * np.linalg.norm(np.cross(tris.vertices[:, 1] - tris.vertices[:, 0],
                                         tris.vertices[:, 2] - tris.vertices[:, 0]), axis=1)
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


def cone_directions(axes: np.ndarray, half_angle: float, count: int, rng: np.random.Generator) -> np.ndarray:
    """`count` directions uniform in solid angle over the cap of `half_angle` about each unit axis (K, 3):
    (K, count, 3). cos(theta) uniform in [cos a, 1] is uniform in solid angle."""
    k = len(axes)
    cz = 1.0 - rng.random((k, count)) * (1.0 - math.cos(half_angle))
    sz = np.sqrt(np.maximum(1.0 - cz * cz, 0.0))
    phi = 2.0 * math.pi * rng.random((k, count))
    frames = np.array([vct_math.tangent_frame(a) for a in axes])  # (K, 3, 3): rows t, b, n
    local = np.stack([sz * np.cos(phi), sz * np.sin(phi), cz], -1)  # (K, count, 3)
    return np.einsum("kcj,kjd->kcd", local, frames)


def voxel_radiance(faces: np.ndarray, lo: np.ndarray, voxel: float, points: np.ndarray,
                   normals: np.ndarray) -> np.ndarray:
    """The grey radiance the voxels hold for surfaces at `points` with `normals` (both (M, 3)): level 0's face
    toward the normal's largest component (faces (6, R, R, R, 4), premultiplied by the coverage), read in the
    voxel holding the point or the one of its 26 neighbours where that face is most covered (a surface's point
    can lie in a voxel the conservative voxeliser left to its neighbour), radiance = mean(rgb) / coverage;
    0 where no voxel near the point holds that face."""
    res = faces.shape[1]
    f = np.argmax(normals @ FACE_AXES.T, axis=1)
    base = np.floor((points - lo) / voxel).astype(np.int64)
    best_a = np.zeros(len(points))
    best_rgb = np.zeros(len(points))
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                j = np.clip(base + (dx, dy, dz), 0, res - 1)
                texel = faces[f, j[:, 0], j[:, 1], j[:, 2]]
                better = texel[:, 3] > best_a
                best_a = np.where(better, texel[:, 3], best_a)
                best_rgb = np.where(better, texel[:, :3].mean(1), best_rgb)
    return np.where(best_a > 1e-6, best_rgb / np.maximum(best_a, 1e-6), 0.0)


def exact_cones(ray, tris: Triangles, faces: np.ndarray, lo: np.ndarray, voxel: float, points: np.ndarray,
                directions: np.ndarray, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """The exact cone integrals of the voxels' radiance: rays from points (K, 3) + eps along each cone's
    directions (K, count, 3), first hits from the intersector `ray`: (mean radiance (K,), share of directions
    that meet a surface (K,)). A one-sided surface met from behind blocks and sends nothing; a two-sided one
    sends the radiance of the side the ray meets."""
    k, count, _ = directions.shape
    d = directions.reshape(-1, 3)
    o = np.repeat(points, count, axis=0) + eps * d
    loc, index_ray, index_tri = ray.intersects_location(o, d, multiple_hits=False)
    radiance = np.zeros(k * count)
    hit = np.zeros(k * count, dtype=bool)
    hit[index_ray] = True
    n = tris.normals[index_tri]
    facing = np.einsum("mj,mj->m", n, d[index_ray]) < 0.0
    two = tris.two_sided[tris.object_id[index_tri]]
    n = np.where((~facing & two)[:, None], -n, n)
    sends = facing | two
    radiance[index_ray] = np.where(sends, voxel_radiance(faces, lo, voxel, loc, n), 0.0)
    return radiance.reshape(k, count).mean(1), hit.reshape(k, count).mean(1)


def cosine_directions(normals: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """`count` directions with density cos / pi about each unit normal (P, 3): (P, count, 3) (Malley: uniform in
    the unit disc, lifted to the hemisphere)."""
    u1, u2 = rng.random((len(normals), count)), rng.random((len(normals), count))
    r, phi = np.sqrt(u1), 2.0 * math.pi * u2
    frames = np.array([vct_math.tangent_frame(n) for n in normals])
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(1.0 - u1, 0.0))], -1)
    return np.einsum("pcj,pjd->pcd", local, frames)


def exact_direct(ray, points: np.ndarray, normals: np.ndarray, albedo: np.ndarray, coeffs: np.ndarray,
                 count: int, eps: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A diffuse surface's direct radiance under the environment's SH9 radiance (coeffs (9, 3)), shadowed by the
    scene: kd / pi int V(w) L(w) cos dw = kd E[V L] over cosine-weighted directions, grey (the channels' mean);
    and the cosine-weighted visibility V = E[V]: ((P,), (P,)). albedo (P, 3)."""
    d = cosine_directions(normals, count, rng)
    o = np.repeat(points, count, axis=0) + eps * d.reshape(-1, 3)
    vis = ~np.asarray(ray.intersects_any(o, d.reshape(-1, 3)), dtype=bool).reshape(len(points), count)
    radiance = sh9(d) @ coeffs  # (P, count, 3), unclamped: the radiance whose cosine integral is the injection's E(n)
    direct = (albedo[:, None, :] * radiance * vis[..., None]).mean(1).mean(-1)
    return direct, vis.mean(1)


@dataclass
class ConeRows:
    """Per point and cone: VCT's gathered grey radiance and opacity, the exact ones; and the cone weights."""
    object_id: np.ndarray  # (P,)
    vct_radiance: np.ndarray  # (P, CONES)
    vct_opacity: np.ndarray
    exact_radiance: np.ndarray
    exact_opacity: np.ndarray
    weights: np.ndarray  # (CONES,), sum pi
    injected: np.ndarray  # (P,) the voxels' radiance at each point
    exact_direct: np.ndarray  # (P,) the exactly shadowed direct radiance under the same SH9 environment
    unshadowed_times_v: np.ndarray  # (P,) kd / pi E(n) V_exact: the injection's form with the exact visibility


def voxelise(scene, resolution: int) -> tuple[VoxelScene, np.ndarray, np.ndarray]:
    """The scene voxelised and injected at `resolution`^3 (one cascade, six cones, step 0.5, the scene's
    environment as SH9 from a 64^2 filter, as E10's probes do): (the voxels, which the caller releases, the SH9
    radiance coefficients (9, 3), the irradiance matrices M (3, 4, 4) the injection's E(n) = n^T M n uses)."""
    ctx = get_context()
    env = environment_store(ctx, scene)
    env.fill_base(scene.environment.rotation_deg)
    env.build_chain(None)
    env.project_sh(64)
    vs = VoxelScene(ctx, scene.objects, resolution, 1, CONES, 0.5)
    vs.update(None, env.sh_buffer)
    coeffs, irradiance = env.read_sh()
    env.release()
    return vs, coeffs, irradiance


def gather(scene, resolution: int, per_object: int, rays: int, seed: int) -> ConeRows:
    """Voxelise and inject the scene (`voxelise`), then trace and ray cast every point's six diffuse cones and
    cast its exact direct light."""
    vs, coeffs, irradiance = voxelise(scene, resolution)
    try:
        rng = np.random.default_rng(seed)
        tris = scene_triangles(scene.objects)
        points, normals, ids = surface_points(tris, per_object, rng)
        h = vs.grid.voxel_size
        lo = grid_lower_corner(vs)
        cones = vct_math.cone_set(CONES)
        axes = np.einsum("cj,pjd->pcd", cones.directions, np.array([vct_math.tangent_frame(n) for n in normals]))
        p = len(points)
        rep = np.repeat
        r = vs.trace_cone(rep(points + NORMAL_OFFSET_VOXELS * h * normals, CONES, 0), axes.reshape(-1, 3),
                          np.full(p * CONES, math.tan(cones.half_angle)), np.full(p * CONES, START_OFFSET_VOXELS * h),
                          rep(points, CONES, 0), rep(normals, CONES, 0))
        faces = vs.read_faces(0)[:, 0]
    finally:
        vs.release()
    ray = scene_intersector(tris)
    dirs = cone_directions(axes.reshape(-1, 3), cones.half_angle, rays, rng)
    eps = ray_offset(tris)
    ex_l, ex_a = exact_cones(ray, tris, faces, lo, h, rep(points, CONES, 0), dirs, eps)
    albedo = np.array([scene.objects[i].material.kd for i in ids], dtype=np.float64)
    direct, v_exact = exact_direct(ray, points, normals, albedo, coeffs, rays, eps, rng)
    n4 = np.c_[normals, np.ones(p)]
    e_sh = np.maximum(np.einsum("pi,cij,pj->pc", n4, irradiance, n4), 0.0)  # the injection's E(n), per channel
    ao = (albedo / math.pi * e_sh).mean(1) * v_exact
    return ConeRows(ids, r[:, :3].mean(1).reshape(p, CONES), r[:, 3].reshape(p, CONES),
                    ex_l.reshape(p, CONES), ex_a.reshape(p, CONES), cones.weights,
                    voxel_radiance(faces, lo, h, points, normals), direct, ao)


def ratio(a: np.ndarray, b: np.ndarray) -> float:
    """sum(a) / sum(b); nan where b sums to 0 (nothing to gather)."""
    s = float(b.sum())
    return float(a.sum()) / s if s > 0.0 else float("nan")


def summary(rows: ConeRows, names: list[str]) -> list[str]:
    """One markdown row per object and one for all: E = sum_k w_k L_k VCT over exact, per cone L VCT over exact,
    per cone opacity VCT / exact."""
    out = ["| object | E VCT / exact | L VCT / exact, cones 0-5 | opacity VCT / exact, cones 0-5 | injected / exact "
           "direct | injected / E(n) V_exact kd / pi |", "|---|---|---|---|---|---|"]
    groups = [(names[i], rows.object_id == i) for i in np.unique(rows.object_id)] + [("all", rows.object_id >= 0)]
    for name, m in groups:
        e = ratio(rows.vct_radiance[m] @ rows.weights, rows.exact_radiance[m] @ rows.weights)
        per_l = " ".join(f"{ratio(rows.vct_radiance[m, k], rows.exact_radiance[m, k]):.2f}" for k in range(CONES))
        per_a = " ".join(f"{rows.vct_opacity[m, k].mean():.2f}/{rows.exact_opacity[m, k].mean():.2f}"
                         for k in range(CONES))
        inj = ratio(rows.injected[m], rows.exact_direct[m])
        inj_ao = ratio(rows.injected[m], rows.unshadowed_times_v[m])
        out.append(f"| {name} | {e:.3f} | {per_l} | {per_a} | {inj:.3f} | {inj_ao:.3f} |")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="cornell-open")
    ap.add_argument("--resolutions", default="32,64,128")
    ap.add_argument("--points", type=int, default=24, help="points per object")
    ap.add_argument("--rays", type=int, default=512, help="rays per cone for the exact integral")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a scene override")
    a = ap.parse_args()
    spec = a.scene if ":" in a.scene or a.scene.endswith(".toml") else f"builtin:{a.scene}"
    bad = [kv for kv in a.set if "=" not in kv]
    if bad:
        ap.error(f"--set {bad[0]!r}: expected KEY=VALUE")
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
    for res in (int(r) for r in a.resolutions.split(",")):
        rows = gather(scene, res, a.points, a.rays, a.seed)
        print(f"\n{spec} at {res}^3 ({a.points} points an object, {a.rays} rays a cone)")
        print("\n".join(summary(rows, names)), flush=True)


if __name__ == "__main__":
    main()
