"""The two renderers (and the quadrature) agree on back faces and silhouettes.

One rule (scenes/model/materials.py): where the shading normal faces away from the viewer (n.v <= 0), a one-sided
material is black in all three renderers; `material.two_sided = true` flips the normal instead (the reference
wraps its BSDF in Mitsuba's `twosided`). Tested on both sides of a plane at several angles, a cube with shared
vertices (smooth normals: the interpolated normal turns away while the face still faces the viewer), coarse
spheres' rims and a camera inside a sphere, against the reference and the numpy ray cast.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import groundtruth
import realtime
import scenes
from experiments.measure import metrics
from experiments.paper import e06_hostile_cases as hostile
from groundtruth.exact import quadrature, raycast
from tests.helpers import predicted_back

pytestmark = [pytest.mark.gl, pytest.mark.mitsuba]
SIZE, SPP = 32, 64


@pytest.fixture(autouse=True)
def cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


def scene(**ov) -> scenes.Scene:
    base = {"camera.width": SIZE, "camera.height": SIZE, "reference.spp": SPP, "realtime.timing_frames": 1,
            "realtime.warmup_frames": 0}
    return scenes.load("builtin:sphere-blend").with_overrides({**base, **ov})


def plane(elevation_deg: float, distance: float = 3.5, **ov) -> scenes.Scene:
    e = math.radians(elevation_deg)
    return scene(**{"objects.0.shape": "plane", "camera.origin": [0.0, distance * math.sin(e), distance * math.cos(e)],
                    **ov})


def psnr(s, a, b) -> float | None:
    mask = metrics.common_mask(a.mask, b.mask)
    return metrics.psnr(metrics.display(s, a.rgb), metrics.display(s, b.rgb), mask)


@pytest.mark.parametrize("elevation", [-80.0, -45.0, -20.0, -10.0])
@pytest.mark.parametrize("material", ['{ type = "blend" }', '{ type = "diffuse" }', '{ type = "phong" }'])
def test_a_plane_seen_from_below_is_black_in_all_three(elevation, material):
    import tomllib

    mat = tomllib.loads(f"m = {material}")["m"]
    s = plane(elevation, **{"objects.0.material": mat})
    rt, ref, q = realtime.render(s), groundtruth.render(s), quadrature.render(s, subpixels=1)
    assert rt.mask.sum() > 20
    assert (rt.rgb[rt.mask] == 0).all() and (q.rgb[q.mask] == 0).all()
    inner = metrics.common_mask(ref.mask, rt.mask)
    assert (ref.rgb[inner] == 0).all()
    assert psnr(s, rt, ref) == metrics.PSNR_CAP


@pytest.mark.parametrize("elevation", [-60.0, -25.0])
def test_two_sided_from_below_is_the_flipped_plane(elevation):
    two = plane(elevation, **{"objects.0.material.two_sided": True})
    flipped = plane(elevation, **{"objects.0.rotate_deg": [180.0, 0.0, 0.0]})  # its front faces down
    rt_two, rt_flip = realtime.render(two), realtime.render(flipped)
    np.testing.assert_array_equal(rt_two.mask, rt_flip.mask)
    np.testing.assert_allclose(rt_two.rgb, rt_flip.rgb, atol=1e-6)
    assert rt_two.rgb[rt_two.mask].min() > 0
    ref_two, ref_flip = groundtruth.render(two), groundtruth.render(flipped)
    mask = metrics.common_mask(ref_two.mask, ref_flip.mask)
    # the twosided wrapper and the geometrically flipped plane: the same image up to Monte Carlo noise
    assert abs(ref_two.rgb[mask].mean() / ref_flip.rgb[mask].mean() - 1.0) < 0.03
    assert psnr(two, rt_two, ref_two) > 24.0  # 28 dB measured (plane from above: 32.5)


def test_two_sided_changes_nothing_seen_from_the_front():
    one, two = plane(40.0), plane(40.0, **{"objects.0.material.two_sided": True})
    np.testing.assert_array_equal(realtime.render(one).rgb, realtime.render(two).rgb)
    a, b = groundtruth.render(one), groundtruth.render(two)
    mask = metrics.common_mask(a.mask, b.mask)
    assert abs(a.rgb[mask].mean() / b.rgb[mask].mean() - 1.0) < 0.03


def test_the_quadrature_agrees_with_the_reference_on_a_two_sided_plane_from_below():
    s = plane(-35.0, **{"objects.0.material.two_sided": True, "reference.spp": 256})
    ref, q = groundtruth.render(s), quadrature.render(s)
    floor_db = metrics.noise_floor_psnr(metrics.display(s, ref.rgb), metrics.display(s, groundtruth.render(
        s, seed=7).rgb), metrics.common_mask(ref.mask, q.mask))
    assert psnr(s, q, ref) > floor_db - 3.0


@pytest.fixture(scope="module")
def cube_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cubes")
    out = {}
    for shared in (True, False):
        path = folder / f"cube-{shared}.obj"
        path.write_text(hostile.cube_obj(shared))
        out[shared] = str(path)
    return out


@pytest.mark.parametrize("rotate", [[30.0, 40.0, 0.0], [-20.0, 125.0, 10.0], [55.0, 15.0, 0.0]])
def test_a_shared_vertex_cube_is_black_where_its_normals_turn_away(cube_files, rotate):
    s = scene(**{"objects.0.shape": cube_files[True], "objects.0.rotate_deg": rotate, "objects.0.scale": 1.3})
    rt, ref = realtime.render(s), groundtruth.render(s)
    hit, back = predicted_back(s)
    black = rt.mask & (rt.rgb == 0).all(-1)
    assert back.sum() > 10  # the case this test is about
    agree = (black == back)[hit & rt.mask].mean()
    assert agree > 0.97, agree  # pixel centres on the n.v = 0 line may fall either way
    from scipy.ndimage import binary_erosion

    core = binary_erosion(back, iterations=1) & ref.mask
    lit = rt.mask & ~black
    assert ref.rgb[core].mean() < 1e-3 * ref.rgb[lit & ref.mask].mean()  # the reference is black there too
    assert psnr(s, rt, ref) > 16.0  # 18.7 dB measured at 32 px (12.6 dB before the rule at 128 px)


def test_a_cube_with_face_normals_has_no_black_pixels(cube_files):
    s = scene(**{"objects.0.shape": cube_files[False], "objects.0.rotate_deg": [30.0, 40.0, 0.0],
                 "objects.0.scale": 1.3})
    rt = realtime.render(s)
    assert not (rt.mask & (rt.rgb == 0).all(-1)).any()


@pytest.mark.parametrize("resolution", [2, 3, 4, 6])
def test_coarse_sphere_rims_follow_the_same_rule_in_all_three(resolution):
    s = scene(**{"objects.0.resolution": resolution, "camera.width": 48, "camera.height": 48})
    rt, q, ref = realtime.render(s), quadrature.render(s, subpixels=1), groundtruth.render(s)
    hit, back = predicted_back(s)
    assert back.any()
    both = hit & rt.mask
    rt_black = (rt.rgb == 0).all(-1)
    q_black = (q.rgb == 0).all(-1)
    assert (rt_black == back)[both].mean() > 0.97
    assert (q_black == back)[both & q.mask].mean() > 0.97
    # the reference averages a pixel: where all 4 x 4 sub-pixel rays see a normal turned away it is (nearly) black
    hits = raycast.cast(s, subpixels=4)
    n_dot_v = np.sum(hits.normal * -hits.direction, axis=-1)
    full = (hits.hit & (n_dot_v <= 0)).all(axis=-1) & ref.mask
    if resolution <= 3:
        assert full.any()
    if full.any():
        assert ref.rgb[full].mean() < 0.05 * ref.rgb[both & ~back].mean()


def test_a_camera_inside_a_sphere_sees_only_back_faces():
    s = scene(**{"camera.origin": [0.0, 0.0, 0.3], "objects.0.scale": 2.0})
    rt, ref, q = realtime.render(s), groundtruth.render(s), quadrature.render(s, subpixels=1)
    assert rt.mask.all() and (rt.rgb == 0).all() and (ref.rgb == 0).all() and (q.rgb == 0).all()
    two = realtime.render(s.with_overrides({"objects.0.material.two_sided": True}))
    assert np.isfinite(two.rgb).all() and two.rgb.min() > 0  # lit from inside (real time has no occlusion)


def test_the_physical_model_follows_the_rule_too():
    one = plane(-40.0, **{"reference.model": "physical"})
    two = plane(-40.0, **{"reference.model": "physical", "objects.0.material.two_sided": True})
    a, b = groundtruth.render(one), groundtruth.render(two)
    inner = metrics.common_mask(a.mask, b.mask)
    assert (a.rgb[inner] == 0).all() and b.rgb[inner].mean() > 0.01 and np.isfinite(b.rgb).all()


# --------------------------------------------------------------------------- the plugin and the key


def _plugin_eval(mi, material, wi, wo):
    import drjit as dr

    from groundtruth.pathtracer import mitsuba_scene, paper_bsdf

    paper_bsdf.register(mi)
    sc = scenes.load("builtin:sphere-blend")
    bsdf = mi.load_dict(mitsuba_scene.bsdf_dict(sc, material))
    si = dr.zeros(mi.SurfaceInteraction3f, len(wo))
    si.wi = mi.Vector3f(*[np.full(len(wo), c) for c in wi])
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    w = mi.Vector3f(wo[:, 0], wo[:, 1], wo[:, 2])
    ctx = mi.BSDFContext()
    return np.array(bsdf.eval(ctx, si, w)).T, np.array(bsdf.pdf(ctx, si, w))


@pytest.mark.parametrize("kind", ["diffuse", "phong", "blend"])
def test_the_plugin_is_zero_behind_the_normal_and_twosided_mirrors_it(mi, rng, kind):
    from scenes.model.scene import Material

    wo = rng.normal(size=(500, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi = np.array([0.3, -0.2, 0.5])
    wi /= np.linalg.norm(wi)
    behind = wi * [1, 1, -1]
    one = Material(kind, exponent=20.0, f0=0.2)
    value, pdf = _plugin_eval(mi, one, behind, wo)
    assert (value == 0).all() and (pdf == 0).all()
    front, _ = _plugin_eval(mi, one, wi, wo)
    two, _ = _plugin_eval(mi, Material(kind, exponent=20.0, f0=0.2, two_sided=True), behind, wo * [1, 1, -1])
    np.testing.assert_allclose(two, front, rtol=1e-5, atol=1e-7)
    assert front.max() > 0


def test_two_sided_is_in_the_reference_key_and_the_rows():
    from groundtruth.pathtracer import reference_cache as cache
    from scenes.model import materials

    one, two = scene(), scene(**{"objects.0.material.two_sided": True})
    env = one.environment.radiance()
    keys = [cache.reference_key(s, env, 8, 0, "v", "3", 4, "direct") for s in (one, two)]
    assert keys[0] != keys[1]
    assert materials.used_fields(two.objects[0].material)["two_sided"] is True
    from experiments.runs import sweep

    assert sweep.content_id(one) != sweep.content_id(two)


@pytest.mark.parametrize("value", ["1", '"yes"', "[true]", "0.0"])
def test_two_sided_must_be_a_boolean(value):
    with pytest.raises(scenes.SceneError, match="material.two_sided .*true or false"):
        scene(**{"objects.0.material.two_sided": value})


@pytest.mark.parametrize("kind", ["diffuse", "phong", "blend"])
def test_every_material_type_takes_two_sided(kind):
    s = scene(**{"objects.0.material": {"type": kind, "two_sided": True}})
    assert s.objects[0].material.two_sided is True
