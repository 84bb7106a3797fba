"""VCT injection of a glossy surface (realtime/techniques/vct/vct_inject.comp), against expectations found
independently: a Phong plane (F = 1) tilted 45 degrees about z, normal n = (1, 1, 0) / sqrt(2), meets a wall
perpendicular to it along the z axis. A voxel of the plane is faced along +x and +y: the +y face holds
what leaves toward +y, whose mirror direction r = +x points into the wall, the +x face what leaves toward
+x, whose r = +y points away from it, to the open sky. Under a constant environment L0:

- direct pass: each face holds ks L0 times the Phong lobe's unblocked share about its r, integrated here
  over the directions the wall (and the plane itself) leave open;
- a bounce pass: the face looking into a diffuse wall holds ks times the wall's radiance where the lobe
  meets it, plus ks L0 times the (nearly nil) unblocked share.

Negative controls: the rule with the diffuse cones' visibility (ks L0 V_d, ks (L0 V_d + E_b / pi) in a
bounce pass), with V_d the cosine-weighted share the wall leaves open, which the same checks reject.

The tests of the faces' stored lobe (the chain's level, the world direction, the horizon share) build the six-face
storage (`deferred_glossy=False`): the deferred glossy read reads the same L_g (vct_glossy_env.glsl) and horizon
share (vct_lobe_above) toward each cone, tests/realtime/test_vct_deferred_glossy.py checks its direction.
"""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

import scenes
from realtime.engine.context import get_context
from realtime.engine.environment_maps import environment_store
from realtime.techniques.vct import vct_math
from realtime.techniques.vct.vct import INJECT_LOD_MIN, VoxelScene
from scenes.environment.shbasis import sh9

pytestmark = pytest.mark.gl

N_EXP, KS, KD_WALL = 50.0, 0.8, 0.5
RES = 32
#: the plane's normal, the in-plane direction toward the wall, the wall's extent along n, z
NORMAL = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
TOWARD_WALL = np.array([1.0, -1.0, 0.0]) / math.sqrt(2.0)
PLANE_LENGTH, WALL_HEIGHT, HALF_DEPTH = 1.2, 1.2, 0.8
GRID = vct_math.Cascades((0.0, 0.42, 0.0), 1.0, RES, 1)
FACE_PX, FACE_NX, FACE_PY = 0, 1, 2


@pytest.fixture(scope="module")
def ctx():

    return get_context()


def quad(corner: np.ndarray, e1: np.ndarray, e2: np.ndarray, normal: np.ndarray, material) -> SimpleNamespace:
    """The parallelogram corner + [0, 1] e1 + [0, 1] e2 as two triangles (counter-clockwise about normal)."""
    p = np.array([corner, corner + e1, corner + e1 + e2, corner + e2], "f8")
    idx = np.array([[0, 1, 2], [0, 2, 3]], "i4")
    if np.dot(np.cross(e1, e2), normal) < 0:
        idx = idx[:, ::-1].copy()
    mesh = SimpleNamespace(positions=p, indices=idx, normals=np.tile(normal, (4, 1)))
    return SimpleNamespace(mesh=mesh, material=material)


def plane_and_wall(wall_kd: float) -> list:
    """The glossy plane {u t + w z: u in [-PLANE_LENGTH, 0]} and the wall {s n + w z: s in [0, WALL_HEIGHT]}
    (diffuse, albedo wall_kd, facing the plane: normal -t), |w| <= HALF_DEPTH."""
    phong = dataclasses.replace(scenes.load("builtin:torus-phong").objects[0].material, ks=(KS,) * 3,
                                exponent=N_EXP)
    diffuse = dataclasses.replace(scenes.load("builtin:sphere-diffuse").objects[0].material, kd=(wall_kd,) * 3)
    z = np.array([0.0, 0.0, 2.0 * HALF_DEPTH])
    back = np.array([0.0, 0.0, -HALF_DEPTH])
    plane = quad(back - PLANE_LENGTH * TOWARD_WALL, PLANE_LENGTH * TOWARD_WALL, z, NORMAL, phong)
    wall = quad(back, WALL_HEIGHT * NORMAL, z, -TOWARD_WALL, diffuse)
    return [plane, wall]


def open_directions(p: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Whether rays from p (on the plane) along dirs (..., 3) escape: above the plane and past the wall."""
    dn, dt, dz = dirs @ NORMAL, dirs @ TOWARD_WALL, dirs[..., 2]
    gap = -float(p @ TOWARD_WALL)  # distance to the wall's plane
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.where(dt > 0.0, gap / dt, np.inf)
        s, w = lam * dn, p[2] + lam * dz
    hits_wall = (dt > 0.0) & (s <= WALL_HEIGHT) & (np.abs(w) <= HALF_DEPTH)
    return (dn > 0.0) & ~hits_wall


def frame_of(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    t = np.cross(helper, axis)
    t /= np.linalg.norm(t)
    return t, np.cross(axis, t)


def lobe_open_share(p: np.ndarray, r: np.ndarray, m: int = 400) -> float:
    """int (N + 1) / (2 pi) (r.l)^N [l open] dl by the midpoint rule in (theta, phi) about r, theta up to
    40 degrees (the lobe's mass beyond: cos^(N+1) 40 deg < 1e-5)."""
    t, b = frame_of(r)
    th = (np.arange(m) + 0.5) * math.radians(40.0) / m
    ph = (np.arange(2 * m) + 0.5) * math.pi / m
    T, P = np.meshgrid(th, ph, indexing="ij")
    d = (np.cos(T)[..., None] * r + (np.sin(T) * np.cos(P))[..., None] * t + (np.sin(T) * np.sin(P))[..., None] * b)
    w = (N_EXP + 1.0) / (2.0 * math.pi) * np.cos(T) ** N_EXP * np.sin(T) * (math.radians(40.0) / m) * (math.pi / m)
    return float((w * open_directions(p, d)).sum())


def cosine_open_share(p: np.ndarray, m: int = 300) -> float:
    """(1 / pi) int cos(theta) [l open] dl over the hemisphere about n (the diffuse cones' visibility)."""
    t, b = frame_of(NORMAL)
    th = (np.arange(m) + 0.5) * (0.5 * math.pi) / m
    ph = (np.arange(2 * m) + 0.5) * math.pi / m
    T, P = np.meshgrid(th, ph, indexing="ij")
    d = (np.cos(T)[..., None] * NORMAL + (np.sin(T) * np.cos(P))[..., None] * t
         + (np.sin(T) * np.sin(P))[..., None] * b)
    w = np.cos(T) * np.sin(T) * (0.5 * math.pi / m) * (math.pi / m) / math.pi
    return float((w * open_directions(p, d)).sum())


def constant_sky(ctx):

    scene = scenes.load("builtin:sphere-on-plane").with_overrides({"environment.map": "builtin:constant"})
    env = environment_store(ctx, scene)
    env.fill_base(0.0)
    env.build_chain(None)
    env.project_sh(64)
    return env


def plane_voxels(vs, near: float, far: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices (K, 3) and centres (K, 3) of the plane's voxels `near` to `far` from the wall (the lobe about
    +x meets it as high above the plane), |z| <= 0.3, none holding the wall (near >= 3 voxels)."""
    occ = vs.occupied(0)
    idx = np.argwhere(occ)
    h = GRID.voxel_size
    x = np.asarray(GRID.centre) - GRID.half_extent + (idx + 0.5) * h
    gap = -(x @ TOWARD_WALL)
    keep = (np.abs(x @ NORMAL) < 0.5 * h) & (gap >= near) & (gap <= far) & (np.abs(x[:, 2]) <= 0.3)
    return idx[keep], x[keep]


def face_radiance(faces: np.ndarray, f: int, idx: np.ndarray) -> np.ndarray:
    """rgb / alpha (grey: the mean of rgb) of face f at voxels idx, from read_faces(0)[:, 0]."""
    v = faces[f][idx[:, 0], idx[:, 1], idx[:, 2]]
    return v[:, :3].mean(axis=1) / v[:, 3]


@pytest.mark.parametrize("store", ["sh9", "env-chain", "deferred"])
def test_glossy_face_injects_only_the_lobe_share_the_wall_leaves_open(ctx, store):
    """Direct pass: the +y face (r = +x, into the wall) holds ks L0 times the lobe's open share (about 0),
    the +x face (r = +y, open) ks L0 times its share (about 1): within 0.05 ks L0 each, in every plane
    voxel 0.2 to 0.4 from the wall. With the deferred glossy read the faces' gloss texels hold the lobe's
    weight ks V_g instead (L0 = 1: the same figures). Control: the diffuse cones' rule, ks L0 V_d with V_d the
    cosine-weighted open share (about 0.5), is rejected by the same bound on the +y face."""

    env = constant_sky(ctx)
    vs = VoxelScene(ctx, plane_and_wall(KD_WALL), RES, 1, 6, 0.5, bounces=1, grid=GRID,
                    env_filter=None if store == "sh9" else env, deferred_glossy=store == "deferred")
    vs.update(None, env.sh_buffer)
    idx, x = plane_voxels(vs, 0.2, 0.4)
    faces = vs.read_faces(0)[:, 0]
    if store == "deferred":  # the lobe's weight over the faces' coverage
        faces = np.concatenate([vs.read_gloss(0)[:, 0, ..., :3], faces[..., 3:]], axis=-1)
    vs.release()
    env.release()
    assert len(idx) >= 20
    on_plane = x - np.outer(x @ NORMAL, NORMAL)
    into = np.array([lobe_open_share(p, np.array([1.0, 0.0, 0.0])) for p in on_plane])
    away = np.array([lobe_open_share(p, np.array([0.0, 1.0, 0.0])) for p in on_plane])
    diffuse_v = np.array([cosine_open_share(p) for p in on_plane])
    got_into = face_radiance(faces, FACE_PY, idx) / KS
    got_away = face_radiance(faces, FACE_PX, idx) / KS
    assert into.max() < 0.01 and away.min() > 0.99  # the geometry does what the test says
    assert np.abs(got_into - into).max() < 0.05, (got_into, into)
    assert np.abs(got_away - away).max() < 0.05, (got_away, away)
    # control: the diffuse cones' visibility lets half the sky through the wall
    assert np.abs(diffuse_v - into).min() > 0.05, diffuse_v


def test_glossy_bounce_reflects_the_wall_it_faces(ctx):
    """A bounce pass (inject = 2, after the direct pass): the +y face of the plane (r = +x) holds
    ks (L0 s + L_w), s the lobe's open share (integrated here, about 0) and L_w the wall's direct radiance
    toward the plane (its faces' rgb / alpha, read back) within two voxels of where the lobe's axis meets
    it, for plane voxels 0.25 to 0.45 from the wall: within 15 % (the bounce pass reads levels >= 1, whose
    texels average the wall's radiance over two voxels: 3 voxels from the wall, the darker foot of the
    wall reads 20 % high). Control: the diffuse cones' rule ks (L0 V_d + E_b / pi), V_d and E_b the cones'
    visibility and gathered irradiance at the same voxels (VoxelScene.probe at the bounce passes' levels),
    falls outside. The voxels read the glossy term deferred (the frame's default), so the face holds ks L_w and
    the gloss texel the ks s the read evaluates: s is about 0 here, so the same bound holds."""

    env = constant_sky(ctx)
    vs = VoxelScene(ctx, plane_and_wall(KD_WALL), RES, 1, 6, 0.5, bounces=1, grid=GRID, env_filter=env)
    vs.update(None, env.sh_buffer)
    idx, x = plane_voxels(vs, 0.25, 0.45)
    direct = vs.read_faces(0)[:, 0]
    n = np.tile(NORMAL, (len(x), 1))
    cones = vs.probe(x, n, rgb_lod_min=INJECT_LOD_MIN)  # before level 0 is rewritten: the bounce pass's view
    vs.inject(0, 2, env.sh_buffer)
    bounced = vs.read_faces(0)[:, 0]
    vs.release()
    env.release()
    # the wall's voxels (faced along -x and +y: its normal is -t) and their radiance toward -x
    h = GRID.voxel_size
    widx = np.argwhere(direct[FACE_NX][..., 3] > 0)
    wx = np.asarray(GRID.centre) - GRID.half_extent + (widx + 0.5) * h
    widx, wx = widx[np.abs(wx @ TOWARD_WALL) < 0.75 * h], wx[np.abs(wx @ TOWARD_WALL) < 0.75 * h]
    wall_l = face_radiance(direct, FACE_NX, widx)
    # L_w per plane voxel: the wall's mean within 2 voxels of where the lobe's axis (+x) meets it, at the
    # height of the voxel's distance to the wall (+x = (n + t) / sqrt(2)) and its own z
    gap = -(x @ TOWARD_WALL)
    hit = gap[:, None] * NORMAL + x[:, 2:3] * np.array([0.0, 0.0, 1.0])
    near = np.linalg.norm(wx[None, :, :] - hit[:, None, :], axis=-1) <= 2.0 * h
    assert near.sum(axis=1).min() >= 3
    l_w = (near * wall_l).sum(axis=1) / near.sum(axis=1)
    on_plane = x - np.outer(x @ NORMAL, NORMAL)
    share = np.array([lobe_open_share(p, np.array([1.0, 0.0, 0.0])) for p in on_plane])
    want = KS * (share + l_w)
    got = face_radiance(bounced, FACE_PY, idx)
    assert np.abs(got / want - 1.0).max() < 0.15, (got, want)
    old = KS * (cones[:, 3] + cones[:, :3].mean(axis=1) / math.pi)
    assert np.abs(old / want - 1.0).min() > 0.15, (old, want)


#: the frame's injection reads the chain at log2(base sqrt(3)) - 0.5 log2(N + 1) for lobes past the broad-lobe
#: table's (N >= 255): level 2 exactly for base 64 and N + 1 = 3 64^2 / 2^4 = 768
CHAIN_BASE, CHAIN_EXPONENT, CHAIN_LEVEL = 64, 767.0, 2
#: a lobe the broad-lobe table reads (below its top exponent, 127)
TABLE_EXPONENT = 31.0


def central_mean(env, face: int, level: int) -> np.ndarray:
    """The mean radiance (3,) of cube `face`'s four central texels at `level` of the chain the cones read, weighted
    by solid angle (EnvironmentFilter.solid_angle_chain: texels (rgb w, w)), as a trilinear lookup at their common
    corner blends them."""
    s = CHAIN_BASE >> level
    t = env.read_level(level, weighted=True)[face, s // 2 - 1:s // 2 + 1, s // 2 - 1:s // 2 + 1].reshape(-1, 4)
    return t[:, :3].sum(axis=0) / t[:, 3].sum()


def test_frame_injection_reads_the_lobe_level_of_the_environment_chain(ctx):
    """A horizontal Phong plane (N = 767, past the broad-lobe table) alone under a sky whose sun stands at the
    zenith, the environment store (base 64) passed as the frame passes it: the upper face (r = +y, open sky) holds
    ks times the chain's radiance at +y at level 2 (the level whose texel covers the lobe's 2 pi / (N + 1) sr): +y is
    the corner of the +Y face's four central texels, so the trilinear lookup is their mean (weighted by
    solid angle, as the cones' chain holds them), read back here from the chain; within 1 %. Controls: the
    same mean at levels 1 and 3, and the SH9 rule (the lobe convolved in SH9), differ from it by more
    than 10 %."""

    scene = scenes.load("builtin:sphere-on-plane").with_overrides({
        "environment.map": "builtin:sky", "environment.params.sun_elevation_deg": 90.0,
        "environment.params.sun": 1e3, "realtime.base_size": CHAIN_BASE})
    env = environment_store(ctx, scene)
    env.fill_base(0.0)
    env.build_chain(None)
    env.project_sh(64)
    phong = dataclasses.replace(scenes.load("builtin:torus-phong").objects[0].material, ks=(KS,) * 3,
                                exponent=CHAIN_EXPONENT)
    plane = SimpleNamespace(mesh=scene.objects[1].mesh, material=phong)
    vs = VoxelScene(ctx, [plane], 32, 1, 6, 0.5, grid=vct_math.Cascades((0.0, 0.5 * 4.4 / 32, 0.0), 2.2, 32, 1),
                    env_filter=env, deferred_glossy=False)
    vs.update(None, env.sh_buffer)
    up = vs.read_faces(0)[FACE_PY, 0, 8:24, 15, 8:24].reshape(-1, 4)
    got = up[:, :3] / up[:, 3:4] / KS

    want = central_mean(env, 2, CHAIN_LEVEL)
    others = [central_mean(env, 2, CHAIN_LEVEL - 1), central_mean(env, 2, CHAIN_LEVEL + 1)]
    coeffs, _ = env.read_sh()
    lam = np.repeat([1.0, (CHAIN_EXPONENT + 1) / (CHAIN_EXPONENT + 2), CHAIN_EXPONENT / (CHAIN_EXPONENT + 3)],
                    [1, 3, 5])
    others.append(np.maximum((lam * sh9(np.array([0.0, 1.0, 0.0]))) @ coeffs, 0.0))
    vs.release()
    env.release()
    assert np.abs(got / want - 1.0).max() < 0.01, (got[:3], want)
    for other in others:
        assert np.abs(other / want - 1.0).max() > 0.1, (other, want)


def test_frame_injection_looks_up_the_world_direction_in_a_turned_environment(ctx):
    """The glossy read's direction convention: a vertical Phong plane facing +x (N = 31, a lobe the broad-lobe
    table reads) under the calibration map (no turn about +Y maps it onto itself) turned 37 degrees. The store is
    filled in the world frame, so the +X face (r = +x) must hold ks times the lobe's integral about world +x,
    summed in numpy over the store's base level (vct_math.lobe_integrals); within 2 %.
    Controls: the same integrals about -x, +z and -z (an axis swapped or negated in the lookup, or the turn
    applied twice or not at all reading another direction) differ from it by more than 10 %."""
    rotation = 37.0
    scene = scenes.load("builtin:sphere-on-plane").with_overrides({
        "environment.map": "builtin:calibration", "environment.rotation_deg": rotation,
        "realtime.base_size": CHAIN_BASE})
    env = environment_store(ctx, scene)
    env.fill_base(rotation)
    env.build_chain(None)
    env.project_sh(64)
    phong = dataclasses.replace(scenes.load("builtin:torus-phong").objects[0].material, ks=(KS,) * 3,
                                exponent=TABLE_EXPONENT)
    wall = quad(np.array([0.0, -1.5, -1.5]), np.array([0.0, 3.0, 0.0]), np.array([0.0, 0.0, 3.0]),
                np.array([1.0, 0.0, 0.0]), phong)
    vs = VoxelScene(ctx, [wall], 32, 1, 6, 0.5, grid=vct_math.Cascades((0.5 * 4.4 / 32, 0.0, 0.0), 2.2, 32, 1),
                    env_filter=env, deferred_glossy=False)
    vs.update(None, env.sh_buffer)
    east = vs.read_faces(0)[FACE_PX, 0, 15, 8:24, 8:24].reshape(-1, 4)
    got = east[:, :3] / east[:, 3:4] / KS
    axes = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    integrals = vct_math.lobe_integrals(env.read_level(0), axes, TABLE_EXPONENT, size=CHAIN_BASE)
    vs.release()
    env.release()
    want, others = integrals[0], integrals[1:]
    assert np.abs(got / want - 1.0).max() < 0.02, (got[:3], want)
    for other in others:
        assert np.abs(other / want - 1.0).max() > 0.1, (other, want)


@pytest.mark.parametrize("tilt", [0.05, 0.1])
def test_a_grazing_glossy_face_injects_the_lobes_share_above_the_horizon(ctx, tilt):
    """A lone Phong plane tilted so that n . x = tilt, under a constant sky: its voxels' +x face is faced
    (n . x > 0) and its mirror direction r = reflect(-x, n) grazes the plane (n . r = tilt). Nothing blocks
    the lobe, but the reference's BSDF weights its directions below the plane 0: the face holds ks L0 times
    the lobe's share above the horizon, vct_math.lobe_above_horizon (0.64 and 0.76 here, itself checked
    against sampling the lobe), not ks L0 (the control: 1 is outside the bound)."""
    n = np.array([tilt, math.sqrt(1.0 - tilt * tilt), 0.0])
    t = np.array([n[1], -n[0], 0.0])
    phong = dataclasses.replace(scenes.load("builtin:torus-phong").objects[0].material, ks=(KS,) * 3,
                                exponent=N_EXP)
    centre = np.asarray(GRID.centre)
    plane = quad(centre - 0.8 * t - np.array([0.0, 0.0, 0.8]), 1.6 * t, np.array([0.0, 0.0, 1.6]), n, phong)
    env = constant_sky(ctx)
    vs = VoxelScene(ctx, [plane], RES, 1, 6, 0.5, bounces=1, grid=GRID, env_filter=env, deferred_glossy=False)
    vs.update(None, env.sh_buffer)
    occ = vs.occupied(0)
    faces = vs.read_faces(0)[:, 0]
    vs.release()
    env.release()
    idx = np.argwhere(occ)
    x = centre - GRID.half_extent + (idx + 0.5) * GRID.voxel_size
    keep = (np.abs((x - centre) @ n) < 0.5 * GRID.voxel_size) & (np.abs(x[:, 2]) < 0.4) \
        & (np.abs((x - centre) @ t) < 0.4)
    assert keep.sum() >= 20
    got = face_radiance(faces, FACE_PX, idx[keep]) / KS
    share = vct_math.lobe_above_horizon(tilt, N_EXP)
    assert share < 0.8
    assert np.abs(got - share).max() < 0.05, (got, share)
    assert np.abs(got - 1.0).min() > 0.15  # the control: the whole lobe
