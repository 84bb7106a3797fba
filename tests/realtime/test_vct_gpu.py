"""Voxel cone tracing on the GPU (realtime/techniques/vct/vct.py), against expectations found independently:

- voxelisation: a sphere's occupied voxels lie in its analytic shell and number between its surface
  area over a voxel face and the surface-voxel bound; an axis-aligned plane fills exactly one layer;
- the anisotropic mip on the GPU equals vct_math.anisotropic_mip (a voxel half filled along +X reads
  opaque from +-X and half opaque from the other axes);
- a single convex object: VCT occlusion changes nothing (its image equals the direct-only image);
- a plane under a sphere of radius r at height h: the cones' visibility is the analytic 1 - (r/h)^2
  within one voxel of radius either way;
- energy: in a closed white box lit through a small opening, the gathered irradiance grows with the
  bounces and stays under the geometric series E_1 (1 - rho^k) / (1 - rho);
- the frame reports `voxelize` and `mip`, the voxel memory, and interreflection only adds light.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from types import SimpleNamespace

import numpy as np
import pytest

import realtime
import scenes
from realtime.techniques.vct import vct_math

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def ctx():
    from realtime.engine.context import get_context

    return get_context()


def sh_of(ctx, scene):
    from realtime.engine.environment_maps import environment_store

    env = environment_store(ctx, scene)
    env.fill_base(scene.environment.rotation_deg)
    env.build_chain(None)
    env.project_sh(64)
    return env


def voxels(ctx, objects, res, cascades=1, bounces=1, grid=None, env=None):
    from realtime.techniques.vct.vct import VoxelScene

    vs = VoxelScene(ctx, objects, res, cascades, 6, 0.5, bounces=bounces, grid=grid)
    if env is not None:
        vs.update(None, env.sh_buffer)
    else:
        vs.voxelize()
    return vs


def obj(positions, indices, normals, kd=(0.8, 0.8, 0.8), two_sided=False):
    material = dataclasses.replace(scenes.load("builtin:sphere-diffuse").objects[0].material, kd=tuple(kd),
                                   two_sided=two_sided)
    mesh = SimpleNamespace(positions=np.asarray(positions, "f8"), indices=np.asarray(indices, "i4"),
                           normals=np.asarray(normals, "f8"))
    return SimpleNamespace(mesh=mesh, material=material)


def test_sphere_voxels_lie_in_its_shell_within_the_surface_bound(ctx):
    sphere = scenes.load("builtin:sphere-diffuse").objects[0]  # radius 1, centred at the origin
    grid = vct_math.Cascades((0.0, 0.0, 0.0), 1.25, 32, 1)
    vs = voxels(ctx, [sphere], 32, grid=grid)
    occ = vs.occupied(0)
    h = grid.voxel_size
    idx = np.argwhere(occ)
    centres = -1.25 + (idx + 0.5) * h
    r = np.linalg.norm(centres, axis=1)
    # a voxel touched by the surface has its centre within half a diagonal of it
    assert (np.abs(r - 1.0) <= math.sqrt(3) / 2 * h + 1e-6).all()
    count = len(idx)
    assert 4 * math.pi / h ** 2 <= count <= vct_math.surface_voxel_bound(1.0, h)
    # closed: the empty voxels inside are cut off from those outside (no gap in the shell, 6-connected)
    from scipy import ndimage

    labels, _ = ndimage.label(~occ)
    assert labels[16, 16, 16] != 0 and labels[16, 16, 16] != labels[0, 0, 0]
    vs.release()


def test_axis_aligned_plane_fills_exactly_one_layer(ctx):
    plane = scenes.load("builtin:sphere-on-plane").objects[1]  # y = 0, half size 2
    h = 4.4 / 32
    grid = vct_math.Cascades((0.0, 0.5 * h, 0.0), 2.2, 32, 1)  # y = 0 is a layer's centre plane
    vs = voxels(ctx, [plane], 32, grid=grid)
    occ = vs.occupied(0)
    layers = np.flatnonzero(occ.any(axis=(0, 2)))
    assert list(layers) == [15]
    # the layer is filled where the plane is (|x|, |z| <= 2 of the grid's +-2.2)
    inside = np.abs(-2.2 + (np.arange(32) + 0.5) * h) < 2.0 - h
    assert occ[np.ix_(inside, [15], inside)].all()
    vs.release()


def test_gpu_anisotropic_mip_matches_the_six_face_scheme(ctx):
    plane = scenes.load("builtin:sphere-on-plane").objects[1]
    vs = voxels(ctx, [plane], 8)
    faces = np.zeros((6, 1, 8, 8, 8, 4), "f4")
    faces[:, 0, 1::2, :, :] = [0.25, 0.5, 0.125, 1.0]  # every odd x: the +X half of each 2x2x2 block
    faces[1, 0, 1::2, :, :] = [0.0, 0.75, 0.0, 1.0]  # the filled half emits green toward -X
    faces[:, 0, 0:2, 0:2, 0:2] = [0.0, 0.0, 0.5, 0.5]  # one block: half-transparent blue in front
    vs.write_level0(faces)
    vs.build_mips()
    gpu = vs.read_faces(1)[:, 0]
    want = vct_math.anisotropic_mip(faces[:, 0].astype(np.float64))
    assert np.allclose(gpu, want, atol=2e-3)
    block = gpu[:, 2, 2, 2]  # a half-filled block
    assert block[0, 3] == pytest.approx(1.0) and block[1, 3] == pytest.approx(1.0)
    assert all(block[f, 3] == pytest.approx(0.5) for f in (2, 3, 4, 5))
    assert not np.allclose(block[0, :3], block[1, :3])  # +X and -X read differently
    vs.release()


def test_single_convex_object_vct_occlusion_changes_nothing(ctx, monkeypatch):
    # sphere-diffuse has no occlusion effect; force the technique in to see what it does to a convex object
    base = scenes.load("builtin:sphere-diffuse").with_overrides({
        "camera.width": 64, "camera.height": 64, "realtime.timing_frames": 1, "realtime.warmup_frames": 0})
    direct = realtime.render(base)
    monkeypatch.setattr(type(base), "effects", property(lambda self: frozenset({"diffuse", "occlusion"})))
    occluded = realtime.render(base.with_overrides({"realtime.occlusion": "vct", "realtime.vct.resolution": 32,
                                                    "realtime.vct.cascades": 1}))
    assert "VCT_OCCLUSION" in occluded.meta["defines"]
    m = direct.mask & occluded.mask
    ratio = occluded.rgb[m].mean() / direct.rgb[m].mean()
    assert ratio == pytest.approx(1.0, abs=0.01)  # stated tolerance: 1 % of the mean
    # per pixel: 99 % of the pixels within 3 %
    rel = np.abs(occluded.rgb[m] - direct.rgb[m]).max(axis=1) / np.maximum(direct.rgb[m].max(axis=1), 1e-6)
    assert np.quantile(rel, 0.99) < 0.03


def test_plane_visibility_under_a_sphere_is_the_analytic_cap(ctx):
    height = 1.0  # a sphere of radius 0.5 half its radius above the plane
    scene = scenes.load("builtin:sphere-on-plane").with_overrides({"objects.0.translate": [0.0, height, 0.0]})
    env = sh_of(ctx, scene)
    vs = voxels(ctx, scene.objects, 64, env=env)
    h = vs.grid.voxel_size
    v = vs.probe(np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))[0, 3]
    lo, hi = vct_math.cap_visibility(0.5 + h, height), vct_math.cap_visibility(0.5 - h, height)
    assert lo <= v <= hi, (v, vct_math.cap_visibility(0.5, height), h)
    vs.release()
    env.release()


def test_plane_alone_sees_the_whole_sky_even_on_a_voxel_boundary(ctx):
    # the plane on a voxel boundary fills two layers (conservative): the offsets must still clear them
    plane = scenes.load("builtin:sphere-on-plane").objects[1]
    scene = scenes.load("builtin:sphere-on-plane")
    env = sh_of(ctx, scene)
    for centre_y in (0.0, 0.75):
        vs = voxels(ctx, [plane], 64, grid=vct_math.Cascades((0.0, centre_y, 0.0), 2.2, 64, 1), env=env)
        v = vs.probe(np.array([[0.0, 0.0, 0.0], [1.6, 0.0, 1.6]]), np.tile([0.0, 1.0, 0.0], (2, 1)))[:, 3]
        assert (v > 0.99).all(), (centre_y, v)
        vs.release()
    env.release()


def test_distant_occluder_is_over_occluded_as_measured(ctx):
    # a known limit, measured rather than hidden: a sphere (r = 0.5) one diameter above the plane blocks 11 %
    # of the cosine lobe. The footprint rule that keeps cones off their own surface (a sample's voxel at most
    # a third of its height above the tangent plane) narrows the cone along the normal to about a third of
    # its 60-degree width, so an occluder on its axis reads as filling the whole cone (about 26 % blocked
    # here: that cone's share of the lobe). A lod bias (finer voxels) does not change it; a looser rule
    # (2/3 of the height) brings back the plane's self-occlusion.
    scene = scenes.load("builtin:sphere-on-plane").with_overrides({"objects.0.translate": [0.0, 1.5, 0.0]})
    env = sh_of(ctx, scene)
    vs = voxels(ctx, scene.objects, 64, env=env)
    v = vs.probe(np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))[0, 3]
    exact = vct_math.cap_visibility(0.5, 1.5)
    assert exact - 0.2 < v < exact  # darker than exact, by less than 0.2
    vs.release()
    env.release()


def box_with_opening(rho: float, hole: float):
    """A closed unit box [-0.5, 0.5]^3 of one-sided walls facing in, albedo rho, with a square hole of side
    `hole` in the middle of its roof."""
    out = []
    n = 8
    c = np.linspace(-0.5, 0.5, n + 1)
    for axis in range(3):
        for sign in (-1.0, 1.0):
            pts, tris = [], []
            u, w = [a for a in range(3) if a != axis]
            for i in range(n):
                for j in range(n):
                    a0, a1, b0, b1 = c[i], c[i + 1], c[j], c[j + 1]
                    if axis == 1 and sign > 0 and max(abs(a0 + a1), abs(b0 + b1)) / 2 < hole / 2:
                        continue  # the opening
                    quad = []
                    for a, b in ((a0, b0), (a1, b0), (a1, b1), (a0, b1)):
                        p = np.zeros(3)
                        p[axis], p[u], p[w] = 0.5 * sign, a, b
                        quad.append(p)
                    k = len(pts)
                    pts += quad
                    tris += [(k, k + 1, k + 2), (k, k + 2, k + 3)]
            normal = np.zeros(3)
            normal[axis] = -sign  # facing in
            out.append(obj(pts, tris, np.tile(normal, (len(pts), 1)), kd=(rho, rho, rho)))
    return out


def test_energy_grows_with_bounces_under_the_geometric_series(ctx):
    rho = 0.8
    objects = box_with_opening(rho, 0.25)
    scene = scenes.load("builtin:sphere-diffuse")
    env = sh_of(ctx, scene)
    grid = vct_math.Cascades((0.0, 0.0, 0.0), 0.6, 32, 1)
    # the area average over the six inner walls (the geometric series bounds the box's total power,
    # not any one point's irradiance), each point a little inside, facing in
    xs = np.linspace(-0.35, 0.35, 5)
    pts, normals = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u, w = [a for a in range(3) if a != axis]
            for a in xs:
                for b in xs:
                    p = np.zeros(3)
                    p[axis], p[u], p[w] = 0.45 * sign, a, b
                    n = np.zeros(3)
                    n[axis] = -sign
                    pts.append(p)
                    normals.append(n)
    pts, normals = np.array(pts), np.array(normals)
    gathered = []
    for k in (1, 2, 3, 4):
        vs = voxels(ctx, objects, 32, bounces=k, grid=grid, env=env)
        gathered.append(vs.probe(pts, normals)[:, :3].mean())
        vs.release()
    env.release()
    e1 = gathered[0]
    assert e1 > 0
    for k in range(1, 4):
        assert gathered[k] >= gathered[k - 1] * (1 - 1e-3)  # grows with the bounces
        bound = e1 * (1 - rho ** (k + 1)) / (1 - rho)
        assert gathered[k] <= bound * 1.001, (k, gathered, bound)
    assert gathered[3] > gathered[0] * 1.05  # the later bounces do add light


def test_frame_reports_voxelize_mip_memory_and_bounce_adds_light():
    base = scenes.load("builtin:sphere-on-plane").with_overrides({
        "camera.width": 48, "camera.height": 48, "realtime.timing_frames": 1, "realtime.warmup_frames": 0,
        "realtime.occlusion": "vct", "realtime.vct.resolution": 32, "realtime.vct.cascades": 2})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        occ = realtime.render(base)
        both = realtime.render(base.with_overrides({"realtime.interreflection": "vct"}))
        direct = realtime.render(scenes.load("builtin:sphere-on-plane").with_overrides({
            "camera.width": 48, "camera.height": 48, "realtime.timing_frames": 1, "realtime.warmup_frames": 0}))
    for r in (occ, both):
        assert {"voxelize", "mip", "draw", "total"} <= set(r.timings)
        total = sum(r.timings[k] for k in ("filter", "voxelize", "mip", "draw"))
        assert r.timings["total"] == pytest.approx(total, rel=1e-6)
    meta = occ.meta["vct"]
    assert meta["cascades"] == 2 and len(meta["bytes_per_cascade"]) == 2
    assert meta["bytes"] < meta["single_texture_bytes"]
    assert occ.meta["unsimulated_effects"] == ["interreflection"] and both.meta["unsimulated_effects"] == []
    m = occ.mask & both.mask & direct.mask
    assert occ.rgb[m].mean() < direct.rgb[m].mean()  # occlusion takes light away
    assert (both.rgb[m] >= occ.rgb[m] - 1e-6).all()  # the bounce only adds it back
    assert both.rgb[m].mean() > occ.rgb[m].mean()
