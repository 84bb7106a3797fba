"""Wavelet PRT's precomputation, numpy + Embree (realtime/techniques/wavelet_prt/wavelet_transfer.py), against
expectations computed here: a brute-force sum over cube texels of visibility x cosine x radiance with this file's
own ray-triangle test (Moller & Trumbore 1997, every triangle, no acceleration, edges
widened by 1e-9 so that it is watertight like Embree's), the irradiance of a convex
sphere, a single-texel light, the bounce series of an integrating sphere, and the storage rule re-applied to the
dense transfer. Controls: a mirrored or transposed lighting face, a wrong albedo, a lower threshold."""

from __future__ import annotations

import numpy as np
import pytest

import scenes
from realtime.engine import transfer_rays
from realtime.techniques.irradiance_map.irradiance_convolution import irradiance_cube_numpy
from realtime.techniques.wavelet_prt import haar
from realtime.techniques.wavelet_prt import wavelet_transfer as wt
from realtime.techniques.wavelet_prt.wavelet_prt import transfer_objects
from scenes.environment import cubemap
from scenes.storage.disk_cache import CacheWarning

from .test_prt_transfer import RHO, open_sphere


def scene_objects(name: str, resolution: int):
    scene = scenes.load(name).with_overrides({"objects.*.resolution": resolution, "environment.rotation_deg": 30.0})
    return scene, transfer_objects(scene)


def blocked(origins: np.ndarray, dirs: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(R,) whether each ray hits any triangle at t > 0 (Moller & Trumbore 1997), rays x all triangles."""
    out = np.zeros(len(origins), dtype=bool)
    p0, e1, e2 = triangles[:, 0], triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    for s in range(0, len(origins), 2048):
        o, d = origins[s:s + 2048, None, :], dirs[s:s + 2048, None, :]
        p = np.cross(d, e2[None])
        det = np.einsum("rti,ti->rt", p, e1)
        ok = np.abs(det) > 1e-14
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        tv = o - p0[None]
        u = np.einsum("rti,rti->rt", tv, p) * inv
        q = np.cross(tv, e1[None])
        v = np.einsum("rti,rti->rt", np.broadcast_to(d, q.shape), q) * inv
        t = np.einsum("ti,rti->rt", e2, q) * inv
        # edges widened by 1e-9 (barycentric): a ray through an edge shared by two triangles hits at least
        # one of them (the plain test can pass between both by rounding; Embree's test is watertight)
        out[s:s + 2048] = (ok & (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9) & (t > 0)).any(axis=1)
    return out


def brute_force(objects, faces: np.ndarray, shadowed: bool) -> list[np.ndarray]:
    """E (V, 3) per object: sum over texels of L_t V cos+ dOmega_t, visibility by `blocked` from x + eps n with
    eps = 1e-4 of the bounding box's diagonal."""
    size = faces.shape[1]
    dirs = cubemap.texel_directions(size).reshape(-1, 3)
    omega = np.tile(cubemap.texel_solid_angles(size).reshape(-1), 6)
    radiance = faces.reshape(-1, 3).astype(np.float64)
    p_all = np.concatenate([o.positions for o in objects])
    eps = 1e-4 * np.linalg.norm(p_all.max(axis=0) - p_all.min(axis=0))
    tris = np.concatenate([o.positions[o.indices] for o in objects])
    out = []
    for o in objects:
        n = o.normals / np.linalg.norm(o.normals, axis=1, keepdims=True)
        w = np.maximum(n @ dirs.T, 0.0) * omega  # (V, N)
        if shadowed:
            vi, ti = np.nonzero(w > 0)
            hit = blocked(o.positions[vi] + eps * n[vi], dirs[ti], tris)
            w[vi[hit], ti[hit]] = 0.0
        out.append(w @ radiance)
    return out


def full(transfers, faces):
    lighting = wt.lighting_coefficients(faces)
    return [wt.irradiance(t, lighting) for t in transfers]


def float32_bound(transfer, faces) -> np.ndarray:
    """(V, 3) the error float32 storage of the transfer's coefficients may cause: 2^-23 sum_j |w_j| |l_j| (a
    coefficient rounds by at most half an ulp, 2^-24 relative; twice that for the float64 sum's order). In the
    Haar domain the coarse coefficients of a vertex mix texels it sees and texels it does not, so under a sun the
    exact cancellation of the texel domain holds only to this bound."""
    lighting = np.abs(wt.lighting_coefficients(faces))
    dense = np.abs(transfer.dense(len(lighting)))  # (V, N, C)
    return np.finfo(np.float32).eps * np.einsum("vnc,nk->vk", dense, lighting) if dense.shape[2] == 1 else \
        np.finfo(np.float32).eps * np.einsum("vnc,nc->vc", dense, lighting)


@pytest.fixture(scope="module")
def sphere_on_plane():
    scene, objects = scene_objects("builtin:sphere-on-plane", 8)
    faces = cubemap.from_equirect(scene.environment.radiance(), 8, 30.0)
    transfers = wt.transfer(objects, 8, 0.0, 1, 0, shadowed=True)
    return objects, faces, transfers, brute_force(objects, faces, shadowed=True)


def test_all_terms_equal_the_brute_force_texel_sum(sphere_on_plane):
    objects, faces, transfers, want = sphere_on_plane
    got = full(transfers, faces)
    scale = max(np.abs(w).max() for w in want)
    for g, w, t in zip(got, want, transfers, strict=True):
        assert (np.abs(g - w) <= float32_bound(t, faces) + 1e-12 * scale).all()
        assert float32_bound(t, faces).max() < 1e-3 * scale  # and the bound is small
    # the plane is shadowed somewhere: the unshadowed sum is not the expectation
    unshadowed = brute_force(objects, faces, shadowed=False)
    assert np.abs(unshadowed[1] - want[1]).max() > 0.05 * scale


@pytest.mark.parametrize("wrong", ["mirrored face", "transposed texels"])
def test_a_wrong_texel_order_is_caught(sphere_on_plane, wrong):
    objects, faces, transfers, want = sphere_on_plane
    bad = faces[:, :, ::-1] if wrong == "mirrored face" else faces.transpose(0, 2, 1, 3)
    got = full(transfers, np.ascontiguousarray(bad))
    scale = max(np.abs(w).max() for w in want)
    assert max(np.abs(g - w).max() for g, w in zip(got, want, strict=True)) > 1e-3 * scale


@pytest.mark.parametrize("wrong", [None, "turned lighting"])
def test_unshadowed_transfer_is_the_irradiance_map_of_the_same_cube(wrong):
    """No occlusion: at normals n equal to the texel directions of an output cube, E(n) is the irradiance map
    technique's float64 reference of the same cube level (irradiance_convolution.irradiance_cube_numpy, the plain
    sum L max(n.w, 0) dOmega). Control: the lighting turned by a face (+X's texels on +Z) disagrees."""
    size, out = 16, 4
    faces = cubemap.from_equirect(scenes.load("builtin:sphere-diffuse").environment.radiance(), size, 30.0)
    normals = cubemap.texel_directions(out).reshape(-1, 3)
    v = len(normals)
    obj = wt.TransferObject(positions=np.zeros((v, 3)) + np.arange(v)[:, None] * 1e-3, normals=normals,
                            indices=np.array([[0, 1, 2]]), kd=(0.5, 0.5, 0.5))
    lighting = faces[[4, 1, 2, 3, 0, 5]] if wrong else faces
    (got,) = full(wt.transfer([obj], size, 0.0, 1, 0, False), lighting)
    want = irradiance_cube_numpy(faces, out, normalize=False).reshape(-1, 3)
    assert np.allclose(got, want, rtol=0, atol=2e-6 * np.abs(want).max()) == (wrong is None)


@pytest.mark.parametrize("shadowed", [False, True])
def test_a_convex_sphere_gets_the_cube_irradiance(shadowed):
    """No occluder: shadowed or not, E = sum_t L_t max(0, n . w_t) dOmega_t (nothing blocks a texel ray)."""
    scene, objects = scene_objects("builtin:sphere-diffuse", 12)
    faces = cubemap.from_equirect(scene.environment.radiance(), 16, 30.0)
    (got,) = full(wt.transfer(objects, 16, 0.0, 1, 0, shadowed), faces)
    (want,) = brute_force(objects, faces, shadowed=False)
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-6 * np.abs(want).max())


def single_texel(size: int, face: int, row: int, col: int, radiance: float) -> np.ndarray:
    faces = np.zeros((6, size, size, 3), dtype=np.float32)
    faces[face, row, col] = radiance
    return faces


@pytest.mark.parametrize(("face", "row", "col"), [(0, 3, 5), (2, 0, 0), (5, 7, 2)])
def test_a_single_texel_light(face, row, col):
    """All terms: each vertex gets exactly L max(0, n . w_t) dOmega_t of the lit texel. K = 1 keeps the lit
    face's scaling coefficient (haar.py: it ties with the three coarsest details at 3 L / s and has the smallest
    index), i.e. the face's mean L / s^2 spread over the face: E = L / s^2 sum over the face of cos+ dOmega."""
    s, L = 8, 1e6  # a sun-like texel: no overflow in float32
    scene, objects = scene_objects("builtin:sphere-diffuse", 8)
    (t,) = wt.transfer(objects, s, 0.0, 1, 0, shadowed=False)
    light = single_texel(s, face, row, col, L)
    n = objects[0].normals / np.linalg.norm(objects[0].normals, axis=1, keepdims=True)
    dirs = cubemap.texel_directions(s)
    omega = cubemap.texel_solid_angles(s)
    exact = L * np.maximum(n @ dirs[face, row, col], 0.0) * omega[row, col]
    got = wt.irradiance(t, wt.lighting_coefficients(light))
    np.testing.assert_allclose(got, np.repeat(exact[:, None], 3, axis=1), rtol=0, atol=1e-6 * exact.max())
    one, kept = wt.selected_lighting(wt.lighting_coefficients(light), 1)
    assert list(kept) == [face * s * s]
    spread = L / s ** 2 * (np.maximum(n @ dirs[face].reshape(-1, 3).T, 0.0) * omega.reshape(-1)).sum(axis=1)
    e1 = wt.irradiance(t, one)[:, 0]
    np.testing.assert_allclose(e1, spread, rtol=0, atol=1e-6 * spread.max())
    assert np.abs(e1 - exact).max() > 0.1 * exact.max()  # control: K = 1 is not the exact light


def test_the_storage_rule_keeps_what_the_threshold_says(sphere_on_plane):
    objects, faces, transfers, want = sphere_on_plane
    threshold = 1e-2
    sparse = wt.transfer(objects, 8, threshold, 1, 0, shadowed=True)
    n = 6 * 8 * 8
    for dense_t, sparse_t in zip(transfers, sparse, strict=True):
        d = dense_t.dense(n)[..., 0]
        m = np.abs(d)
        expect = (m > 0) & (m >= threshold * m.max(axis=1, keepdims=True))
        got = np.abs(sparse_t.dense(n)[..., 0]) > 0
        assert np.array_equal(got, expect)
        assert sparse_t.nbytes == 4 * (len(d) + 1) + 8 * expect.sum()  # uint32 offsets, (uint32, float32) entries
        assert expect.sum() < (m > 0).sum()  # control: the threshold dropped some (threshold 0 keeps them)
    # what is dropped is small: the irradiance moves by little against its value
    got = full(sparse, faces)
    for g, w in zip(got, want, strict=True):
        assert np.abs(g - w).max() < 0.05 * np.abs(w).max()


@pytest.fixture(scope="module")
def furnace():
    obj, f_area, ff, boundary = open_sphere()
    obj = wt.TransferObject(obj.positions, obj.normals, obj.indices, obj.kd)
    one = np.ones((6, 16, 16, 3), dtype=np.float32)
    energy = {b: full(wt.transfer([obj], 16, 0.0, 512, b, True, seed=3), one)[0] for b in (0, 1, 2)}
    return obj, ff, boundary, energy


def series(f: float, bounces: int, rho: float = RHO) -> float:
    """E_B / (pi L_e) in a sphere with opening fraction f: f sum_{b=0..B} (rho (1 - f))^b."""
    return f * sum((rho * (1 - f)) ** b for b in range(bounces + 1))


@pytest.mark.parametrize("bounces", [0, 1, 2])
def test_integrating_sphere_follows_the_bounce_series(furnace, bounces):
    """Inside an open sphere of albedo RHO under L_e = 1: E / pi = f sum (rho (1 - f))^b, f the opening's form
    factor (Lambert's contour formula, test_prt_transfer.open_sphere). Tolerance: the texel quadrature of the
    opening (measured at b = 0, 1.5 %) plus the gather's Monte Carlo error. Control: RHO - 0.1 is rejected."""
    obj, ff, boundary, energy = furnace
    away = obj.positions[:, 1] < 0.3
    f = ff[away].mean()
    e = energy[bounces][away] / np.pi
    assert np.array_equal(e[:, 1], e[:, 0]) and np.array_equal(e[:, 2], e[:, 0])  # grey walls
    tol = 0.015 * series(f, bounces) + 4 * e[:, 0].std() / np.sqrt(len(e))
    assert abs(e[:, 0].mean() - series(f, bounces)) < tol
    if bounces:
        assert abs(e[:, 0].mean() - series(f, bounces, RHO - 0.1)) > tol


def test_memory_guard_refuses_with_the_bytes(monkeypatch, tmp_path):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))
    scene, objects = scene_objects("builtin:sphere-on-plane", 6)
    vertices = sum(len(o.positions) for o in objects)
    need = wt.transfer_bytes(vertices, 64, 1)
    assert need > vertices * 6 * 64 * 64 * 3 * 4 * 3  # the dense bounce arrays at least
    monkeypatch.setattr(wt, "memory_limit", lambda: need - 1)
    with pytest.raises(MemoryError, match=f"{need} bytes"):
        wt.cached_transfer(objects, 64, 0.0, 16, 1, True)
    monkeypatch.setattr(wt, "memory_limit", lambda: need)  # control: exactly enough is allowed
    wt.check_memory(vertices, 64, 1)


def test_cache_round_trip_and_key(monkeypatch, tmp_path):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))
    scene, objects = scene_objects("builtin:sphere-on-plane", 6)
    first, info = wt.cached_transfer(objects, 8, 1e-4, 1, 0, True)
    again, info2 = wt.cached_transfer(objects, 8, 1e-4, 1, 0, True)
    assert not info["cached"] and info2["cached"] and info2["seconds"] == 0.0
    assert info2["compute_seconds"] == pytest.approx(info["compute_seconds"])
    assert info["bytes_per_vertex"] == pytest.approx(info["bytes"] / info["vertices"])
    for a, b in zip(first, again, strict=True):
        for name in ("offsets", "indices", "values"):
            assert np.array_equal(getattr(a, name), getattr(b, name))


def _changed(obj, **fields):
    return wt.TransferObject(**{"positions": obj.positions, "normals": obj.normals, "indices": obj.indices,
                                "kd": obj.kd, "two_sided": obj.two_sided, **fields})


def test_the_cache_key_changes_with_what_changes_the_transfer_and_only_that():
    """Every input the transfer depends on moves the key; the albedo, the gather's rays and its seed move it only
    with bounces (without, the transfer is the same array: checked, the control of the 'only')."""
    _, objects = scene_objects("builtin:sphere-diffuse", 6)
    o = objects[0]
    key = wt.transfer_key
    bounced = key(objects, 8, 1e-4, 4, 1, True)
    moved = [key(objects, 16, 1e-4, 1, 0, True), key(objects, 8, 1e-3, 1, 0, True), key(objects, 8, 1e-4, 1, 0, False),
             bounced, key([_changed(o, positions=o.positions + 1e-6)], 8, 1e-4, 1, 0, True),
             key([_changed(o, normals=-o.normals)], 8, 1e-4, 1, 0, True),
             key([_changed(o, indices=o.indices[:, ::-1])], 8, 1e-4, 1, 0, True),
             key([_changed(o, kd=(0.1, 0.2, 0.3))], 8, 1e-4, 4, 1, True), key(objects, 8, 1e-4, 8, 1, True),
             key(objects, 8, 1e-4, 4, 1, True, seed=1), key(objects, 8, 1e-4, 4, 2, True)]
    base = key(objects, 8, 1e-4, 1, 0, True)
    assert len({base, *moved}) == 1 + len(moved)
    other_kd = [_changed(o, kd=(0.1, 0.2, 0.3))]
    assert key(other_kd, 8, 1e-4, 7, 0, True, seed=3) == base  # no bounces: albedo, rays, seed do not enter
    a, b = wt.transfer(objects, 8, 1e-4, 1, 0, True), wt.transfer(other_kd, 8, 1e-4, 7, 0, True, seed=3)
    assert all(np.array_equal(x.values, y.values) and np.array_equal(x.indices, y.indices)
               for x, y in zip(a, b, strict=True))


@pytest.mark.parametrize("damage", ["garbage", "truncated", "other_array", "unsorted"])
def test_corrupt_cache_entry_is_recomputed_with_a_warning(tmp_path, monkeypatch, damage):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))
    scene, objects = scene_objects("builtin:sphere-on-plane", 6)
    good, info = wt.cached_transfer(objects, 8, 1e-4, 1, 0, True)
    path = tmp_path / "wavelet_prt" / f"{info['key']}.npz"
    if damage == "garbage":
        path.write_bytes(b"not a zip file")
    elif damage == "truncated":
        path.write_bytes(path.read_bytes()[:200])
    else:
        with np.load(path) as z:
            entry = dict(z)
        if damage == "other_array":  # arrays that are not the ones the checksum covers
            entry["v0"] = entry["v0"] + 1
        else:  # a checksum rewritten over meaningless arrays: a vertex's indices reversed
            lo, hi = entry["o0"][0], entry["o0"][1]
            entry["i0"][lo:hi] = entry["i0"][lo:hi][::-1].copy()
            arrays = [entry[f"{n}{i}"] for i in range(len(objects)) for n in ("o", "i", "v")]
            entry["checksum"] = np.array(transfer_rays.entry_checksum(arrays, str(entry["meta"])))
        with open(path, "wb") as f:
            np.savez(f, **entry)
    with pytest.warns(CacheWarning, match="corrupt"):
        again, info2 = wt.cached_transfer(objects, 8, 1e-4, 1, 0, True)
    assert not info2["cached"]
    assert all(np.array_equal(a.indices, b.indices) and np.array_equal(a.values, b.values)
               for a, b in zip(good, again, strict=True))
    assert wt.cached_transfer(objects, 8, 1e-4, 1, 0, True)[1]["cached"]  # rewritten


def test_selected_lighting_is_haar_select():
    rng = np.random.default_rng(1)
    coeffs = rng.normal(size=(6 * 8 * 8, 3))
    dense, kept = wt.selected_lighting(coeffs, 20)
    assert list(kept) == list(haar.select(haar.selection_keys(coeffs.reshape(6, 8, 8, 3)), 20))
    assert (dense[kept] == coeffs[kept]).all() and np.count_nonzero(dense.any(axis=1)) == 20
