"""The light array and its shadow maps on the GPU (realtime/techniques/lights/lights.py,
realtime/techniques/shadow_maps/shadow_maps.py) against
independent expectations.

- The powers summed on the GPU every frame equal the numpy powers (scenes/environment/light_array.py), and a turning
  environment turns the directions, not the powers.
- A constant environment of radiance 1 lights an unoccluded diffuse sphere to kd within the cosine
  sum's discretisation bound (tests/scenes/test_light_array.py: 1% at 642 lights).
- A point under an opaque plane gets nothing from lights above the plane: with shadow maps the
  sphere under a wide plane is black where the environment shines only from above.
- Shadow maps agree with exact visibility (Embree rays from the same surface points toward the same
  light) everywhere except within a few shadow texels of the shadow's edge.
- The same array through Mitsuba's `directional` emitters (direct lighting) is the same image up to
  the reference's noise: the directions (Mitsuba's point the way the light travels), the power
  units and the glossy lobe all agree.
"""

from __future__ import annotations

import numpy as np
import pytest

import realtime
from scenes.environment import light_array
from scenes.environment.directions import equirect_directions, rotation_y
from scenes.storage import imageio

from .test_render import SIZE, small

pytestmark = pytest.mark.gl

LIGHTS = {"realtime.diffuse": "lights"}


def gpu_array(scene, rotation_deg: float = 0.0):
    """The scene's LightArrayGpu after one frame at `rotation_deg` (and the context's env store)."""
    from realtime.engine import technique
    from realtime.engine.context import get_context
    from realtime.engine.environment_maps import environment_store
    from realtime.techniques.lights.lights import shared_array

    ctx = get_context()
    store = environment_store(ctx, scene)
    frame = technique.Frame(ctx, scene, store, 64, 2, rotation_deg)
    gpu = shared_array(frame)
    gpu.update(frame)
    return gpu, store


@pytest.mark.parametrize("placement,count", [("geodesic", 42), ("geodesic", 642), ("median_cut", 64)])
def test_gpu_powers_equal_the_numpy_powers_and_turn_with_the_map(placement, count):
    scene = small("builtin:sphere-diffuse", **LIGHTS, **{"realtime.lights.placement": placement,
                                                         "realtime.lights.count": count})
    env = scene.environment.radiance()
    want = light_array.make(env, placement, count)
    for deg in (0.0, 75.0):
        gpu, store = gpu_array(scene, deg)
        try:
            np.testing.assert_allclose(gpu.read_powers(), want.powers, rtol=2e-5, atol=1e-6 * want.powers.max())
            np.testing.assert_allclose(gpu.world_directions, want.directions @ rotation_y(deg).T, atol=1e-12)
        finally:
            gpu.release()
            store.release()


def test_constant_environment_lights_a_diffuse_sphere_to_kd():
    scene = small("builtin:sphere-diffuse", **LIGHTS, **{"realtime.lights.count": 642,
                                                         "environment.map": "builtin:constant",
                                                         "objects.0.material.kd": [0.8, 0.5, 0.2]})
    r = realtime.render(scene)
    assert r.mask.sum() > 0.25 * SIZE * SIZE
    ratio = r.rgb[r.mask] / np.array([0.8, 0.5, 0.2])
    assert np.abs(ratio - 1.0).max() < 0.01


def sky_from_above(tmp_path, min_elevation_deg: float = 25.0) -> str:
    """An .exr map of radiance 1 above `min_elevation_deg` and 0 below."""
    d = equirect_directions(64, 128)
    env = np.where(d[..., 1:2] > np.sin(np.radians(min_elevation_deg)), 1.0, 0.0) * np.ones(3)
    path = tmp_path / "above.exr"
    imageio.write_exr(path, env.astype(np.float32))
    return str(path)


def test_a_sphere_under_an_opaque_plane_gets_nothing_from_the_lights_above(tmp_path):
    # every light with power sits above 25 - (one cell's radius, < 10 deg at 162) degrees; from any point
    # of the sphere (radius 0.3 at the origin) a plane at y = 1 of half size 50 blocks every direction
    # above 1.5 degrees
    under = {"environment.map": sky_from_above(tmp_path), "camera.fov_deg": 12.0, **LIGHTS,
             "realtime.lights.count": 162}
    alone = small("builtin:sphere-diffuse", **under, **{"objects.0.scale": 0.3})
    lit = realtime.render(alone)
    assert lit.rgb[lit.mask].mean() > 0.05  # lit from above without the plane
    tree = {**alone.source, "objects": [alone.source.get("objects", [{}])[0],
                                        {"shape": "plane", "scale": 50 / 0.7, "translate": [0.0, 1.0, 0.0],
                                         "material": {"type": "diffuse", "kd": [0.5, 0.5, 0.5]}}]}
    from scenes.model.scene import from_dict

    covered = from_dict(tree, alone.path, tmp_path).with_overrides({"realtime.occlusion": "shadow_maps",
                                                         "realtime.lights.shadow_map_size": 1024})
    r = realtime.render(covered)
    sphere = lit.mask & r.mask
    assert sphere.sum() > 100
    assert r.rgb[sphere].max() < 1e-6
    # the control: the same plane below the sphere (y = -1) blocks nothing that comes from above
    tree["objects"][1]["translate"] = [0.0, -1.0, 0.0]
    below = realtime.render(from_dict(tree, alone.path, tmp_path).with_overrides(
        {"realtime.occlusion": "shadow_maps", "realtime.lights.shadow_map_size": 1024}))
    np.testing.assert_allclose(below.rgb[sphere], lit.rgb[sphere], rtol=1e-4, atol=1e-6)


@pytest.mark.slow
def test_shadow_maps_agree_with_embree_visibility_up_to_the_map_resolution():
    import trimesh

    from groundtruth.exact import raycast
    from realtime.techniques.shadow_maps.shadow_maps import NORMAL_OFFSET_TEXELS, bounding_sphere

    size = 512
    base = small("builtin:sphere-on-plane", **{"environment.map": "builtin:sky", "environment.params.sun": 1e5,
                                               "camera.width": 96, "camera.height": 96, **LIGHTS,
                                               "realtime.lights.placement": "median_cut", "realtime.lights.count": 1})
    shadowed = base.with_overrides({"realtime.occlusion": "shadow_maps", "realtime.lights.shadow_map_size": size})
    lit, dark = realtime.render(base), realtime.render(shadowed)
    # the plane's pixels (object 1), their surface points from the numpy ray caster
    hits = raycast.cast(base, 1)
    plane = (hits.object_id[..., 0] == 1) & lit.mask & dark.mask
    points = hits.position[..., 0, :][plane]
    light = light_array.median_cut(base.environment.radiance(), 1).directions[0] @ \
        rotation_y(base.environment.rotation_deg).T
    meshes = [trimesh.Trimesh(o.mesh.positions, o.mesh.indices, process=False) for o in base.objects]
    tracer = trimesh.util.concatenate(meshes).ray
    _, radius = bounding_sphere(base)
    texel = 2 * radius / size

    def blocked(p: np.ndarray) -> np.ndarray:
        origins = p + 1e-4 * np.array([0.0, 1.0, 0.0])
        return tracer.intersects_any(origins, np.broadcast_to(light, origins.shape))

    exact = blocked(points)
    # near the edge: the visibility changes within a few texels (PCF spans 1.5, the normal offset 1.5)
    reach = (2.0 + NORMAL_OFFSET_TEXELS) * texel
    near_edge = np.zeros(len(points), bool)
    for dx, dz in ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1), (1, -1), (-1, 1)):
        near_edge |= blocked(points + reach * np.array([dx, 0.0, dz]) / np.hypot(dx, dz)) != exact
    ratio = dark.rgb[plane].mean(axis=1) / np.maximum(lit.rgb[plane].mean(axis=1), 1e-12)
    in_shadow = ratio < 0.5
    assert exact.sum() > 50  # the sphere casts a shadow onto the plane
    disagree = in_shadow != exact
    assert not (disagree & ~near_edge).any(), f"{(disagree & ~near_edge).sum()} pixels disagree away from the edge"
    assert np.all(ratio[~exact & ~near_edge] > 0.99) and np.all(ratio[exact & ~near_edge] < 0.01)


@pytest.mark.mitsuba
@pytest.mark.slow
@pytest.mark.parametrize("name,overrides", [
    ("builtin:sphere-diffuse", {"realtime.lights.count": 42}),
    ("builtin:sphere-blend", {"realtime.glossy": "lights", "realtime.lights.placement": "median_cut",
                              "realtime.lights.count": 64, "objects.0.material.exponent": 20.0}),
])
def test_the_array_through_mitsuba_directional_emitters_is_the_same_image(mi, name, overrides):
    from experiments.measure import comparison
    from groundtruth.pathtracer import reference

    scene = small(name, **LIGHTS, **overrides, **{"camera.width": 48, "camera.height": 48,
                                                 "reference.lighting": "light_array", "reference.spp": 1024})
    real = realtime.render(scene)
    ref, ref2 = reference.render_pair(scene)
    result = comparison.compare(real, ref, scene, ref2)
    # the same finite sum on both sides: what is left is the reference's noise (removed by the
    # two-seed estimate) and float precision; 45 dB is a 0.6% RMS difference of the tone-mapped image
    assert result["psnr_unbiased"] > 45.0, result


@pytest.mark.slow
def test_shadow_maps_and_prt_visibility_agree_on_the_same_scene(tmp_path, monkeypatch):
    """Under a constant sky (radiance 1) both estimate the same thing on the plane of sphere-on-plane:
    the visible part of the cosine lobe, E = integral of V max(n.w, 0) dw. Shadow maps sum it over 642
    light directions (each its Voronoi cell's solid angle, error < 1% unoccluded: test_light_array.py),
    PRT by 1024 cosine-distributed Embree rays per vertex (Monte Carlo: 1.6% standard error of the
    occluded part per vertex) and interpolates per vertex. They should agree on the plane's mean within
    the array's discretisation plus the rays' noise (2%), and pixel by pixel within 10% where the plane
    is resolved (away from the contact point, whose shadow is narrower than a plane triangle)."""
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))
    base = {"environment.map": "builtin:constant", "camera.width": 64, "camera.height": 64,
            "objects.0.resolution": 48, "objects.1.resolution": 96}
    sm = realtime.render(small("builtin:sphere-on-plane", **base, **{
        "realtime.diffuse": "lights", "realtime.lights.count": 642, "realtime.occlusion": "shadow_maps",
        "realtime.lights.shadow_map_size": 256}))
    prt = realtime.render(small("builtin:sphere-on-plane", **base, **{
        "realtime.diffuse": "prt", "realtime.occlusion": "prt", "realtime.prt.rays": 1024}))
    from groundtruth.exact import raycast

    hits = raycast.cast(small("builtin:sphere-on-plane", **base), 1)
    plane = (hits.object_id[..., 0] == 1) & sm.mask & prt.mask
    a, b = sm.rgb[plane].mean(axis=1), prt.rgb[plane].mean(axis=1)
    assert plane.sum() > 500
    assert abs(a.mean() / b.mean() - 1.0) < 0.02
    assert np.quantile(np.abs(a / b - 1.0), 0.95) < 0.10
