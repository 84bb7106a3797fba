"""The light array and its shadow maps on the GPU (realtime/techniques/lights/lights.py,
realtime/techniques/shadow_maps/shadow_maps.py) against
independent expectations.

- The powers summed on the GPU every frame equal the numpy powers (scenes/environment/light_array.py), and a turning
  environment turns the directions, not the powers.
- A constant environment of radiance 1 lights an unoccluded diffuse sphere to kd within the cosine
  sum's discretisation bound (tests/scenes/test_light_array.py: 1% at 642 lights).
- The glossy lobe alone (a Phong sphere, kd = 0) under the same constant sky shows ks times the part
  of the normalised lobe above the surface, a closed-form integral over the view angle, within the
  array's discretisation.
- A point under an opaque plane gets nothing from lights above the plane: with shadow maps the
  sphere under a wide plane is black where the environment shines only from above.
- Shadow maps agree with exact visibility (Embree rays from the same surface points toward the same
  light) everywhere except within a few shadow texels of the shadow's edge.
- Their percentage-closer filter softens the sphere's shadow on the plane without moving or resizing
  it: the darkened area and its centroid equal those of the exact (ray-sphere) shadow of the
  receiver lifted by the documented normal offset, to a small fraction of a shadow texel.
- The same array through Mitsuba's `directional` emitters (direct lighting) is the same image up to
  the reference's noise: the directions (Mitsuba's point the way the light travels), the power
  units and the glossy lobe all agree.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import realtime
from realtime.techniques.shadow_maps.shadow_maps import NORMAL_OFFSET_TEXELS, bounding_sphere
from scenes.environment import light_array
from scenes.environment.directions import equirect_directions, rotation_y
from scenes.storage import imageio

from .test_render import SIZE, analytic_sphere, small

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


def clipped_lobe(cos_alpha: np.ndarray, exponent: float, steps: int = 4000) -> np.ndarray:
    """The normalised Phong lobe's integral over the half of the sphere above the surface, for a mirror
    direction r at angle alpha from the normal n: int_{n.l > 0} (N + 1)/(2 pi) max(r.l, 0)^N dl.

    In polar coordinates about r (t from r, p about it) the surface's horizon bounds p:
    n.l = sin a sin t cos p + cos a cos t > 0 holds for |p| < arccos(-cot a cot t) (all p where the
    argument is below -1), so the integral is int_0^{pi/2} (N + 1)/(2 pi) cos^N t sin t 2 arccos(...) dt,
    done here by the midpoint rule. It is 1 at alpha = 0 (the whole lobe above the surface) and
    1 - alpha/pi for N = 0 (two hemispheres overlap in a lune of 2 (pi - alpha) sr)."""
    t = (np.arange(steps) + 0.5) * (np.pi / 2) / steps
    ca = np.clip(np.asarray(cos_alpha, float), -1.0, 1.0)[..., None]
    sa = np.sqrt(1.0 - ca * ca)
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = np.where(sa > 0, -ca * np.cos(t) / (sa * np.sin(t)), -np.inf)
    around = 2.0 * np.arccos(np.clip(bound, -1.0, 1.0))
    lobe = (exponent + 1) / (2 * np.pi) * np.cos(t) ** exponent * np.sin(t) * around
    return lobe.sum(axis=-1) * (np.pi / 2) / steps


@pytest.mark.parametrize("alpha_deg", [0.0, 30.0, 60.0, 90.0, 120.0])
def test_the_clipped_lobe_integral_has_its_closed_forms(alpha_deg):
    """The quadrature of the clipped lobe against two closed forms: N = 0, 1 - alpha/pi (the two
    hemispheres overlap in a lune of 2 (pi - alpha) sr); N = 1, (1 + cos alpha)/2 (the irradiance
    of a surface tilted by alpha under a uniform sky hemisphere, over pi: the sky view factor)."""
    a = np.radians(alpha_deg)
    assert clipped_lobe(np.cos(a), 0.0) == pytest.approx(1.0 - a / np.pi, abs=1e-4)
    assert clipped_lobe(np.cos(a), 1.0) == pytest.approx((1.0 + np.cos(a)) / 2.0, abs=1e-4)


def constant_map(tmp_path, h: int = 128, w: int = 256) -> str:
    """An .exr map of radiance 1, finer than the builtin one (32 x 64), so that a light's cell holds
    about 13 texels at 2562 lights."""
    path = tmp_path / "one.exr"
    imageio.write_exr(path, np.ones((h, w, 3), np.float32))
    return str(path)


@pytest.mark.parametrize("exponent", [0.0, 1.0, 4.0, 16.0])
def test_the_glossy_lobe_alone_under_a_constant_sky_shows_ks_times_the_lobe_above_the_surface(tmp_path, exponent):
    """The white furnace of the glossy lobe: a Phong sphere (no diffuse term) under radiance 1 through
    2562 geodesic lights shows ks times the normalised lobe's integral above the surface,
    `clipped_lobe(n . v, N)` (n . v = n . r for the mirror direction r), the analytic sphere normals
    (test_render.py) giving n . v. Pixels with n . v >= 1/2 (alpha up to 60 deg). The bound: the
    array's sum of the lobe over 2562 cells (each 4 pi / 2562 sr, about 2.3 deg in radius) differs from
    the integral by at most 1.1% there for N <= 16 on this 128 x 256 map (worked out in numpy over
    random normals and mirror directions); the render, with the mesh's interpolated normals and float32,
    is measured at most 1.4% (N = 0) from it, hence 2%.
    A lobe normalised by (N + 2)/(2 pi) is 5.9% (N = 16) to 100% (N = 0) too bright, cos^(N+1) 5.6%
    (N = 16) too dark, a lobe that ignores the surface's horizon 14% (N = 4, 60 deg) too bright."""
    ks = np.array([0.9, 0.6, 0.3])
    scene = small("builtin:sphere-phong", **{"environment.map": constant_map(tmp_path), "realtime.glossy": "lights",
                                             "realtime.lights.count": 2562, "objects.0.material.exponent": exponent,
                                             "objects.0.material.ks": ks.tolist()})
    r = realtime.render(scene)
    n, v, interior = analytic_sphere(scene)
    cos_nv = np.einsum("...i,...i->...", n, v)
    sel = interior & r.mask & (cos_nv >= 0.5)
    assert sel.sum() > 0.2 * SIZE * SIZE
    lobe = clipped_lobe(cos_nv[sel], exponent)
    assert exponent > 4 or lobe.min() < 0.9  # the surface's horizon cuts a tenth of the lobe somewhere in view
    ratio = r.rgb[sel] / (lobe[:, None] * ks)
    assert np.abs(ratio - 1.0).max() < 0.02, np.abs(ratio - 1.0).max()


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


def _ray_hits_ball(origins: np.ndarray, direction: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """Whether the rays origins + t direction (t > 0, unit direction) meet the ball: the analytic test."""
    oc = origins - centre
    b = oc @ direction
    disc = b * b - (np.einsum("...i,...i->...", oc, oc) - radius * radius)
    return (disc > 0.0) & (-b + np.sqrt(np.maximum(disc, 0.0)) > 0.0)


@pytest.fixture(scope="module")
def sun_shadow_on_the_plane() -> dict:
    """sphere-on-plane (a ball of radius 0.5 at (0, 0.5, 0) on the plane y = 0) lit by one light, the
    median cut of a sky with a sun (45 deg up), with and without 64-texel shadow maps (a shadow
    texel of 0.09 world units: the sphere's shadow is about 15 texels across). Per plane pixel
    (camera ray meets y = 0 inside the plane before the ball, all analytic): the rendered visibility
    (shadowed over unshadowed image) and the exact one of the receiver lifted by the normal offset
    (NORMAL_OFFSET_TEXELS shadow texels along +y), and the plane points (x, z)."""
    size = 64
    base = small("builtin:sphere-on-plane", **{"environment.map": "builtin:sky", "environment.params.sun": 1e5,
                                               "camera.width": 128, "camera.height": 128, **LIGHTS,
                                               "realtime.lights.placement": "median_cut", "realtime.lights.count": 1})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the missing interreflection, said by every render of this scene
        lit = realtime.render(base)
        dark = realtime.render(base.with_overrides({"realtime.occlusion": "shadow_maps",
                                                    "realtime.lights.shadow_map_size": size}))
    light = light_array.median_cut(base.environment.radiance(), 1).directions[0] @ \
        rotation_y(base.environment.rotation_deg).T
    cam = base.camera
    origin, rays = np.asarray(cam.origin, float), cam.pixel_rays()
    t = -origin[1] / rays[..., 1]
    points = origin + t[..., None] * rays
    centre, radius = np.array([0.0, 0.5, 0.0]), 0.5
    oc = origin - centre
    b = rays @ oc
    disc = b * b - (oc @ oc - radius * radius)
    ball_first = (disc > 0) & (-b - np.sqrt(np.maximum(disc, 0.0)) < t)
    plane = (t > 0) & (np.abs(points[..., 0]) < 1.9) & (np.abs(points[..., 2]) < 1.9) & ~ball_first
    plane &= lit.mask & dark.mask
    texel = 2.0 * bounding_sphere(base)[1] / size
    lifted = points + NORMAL_OFFSET_TEXELS * texel * np.array([0.0, 1.0, 0.0])
    exact = _ray_hits_ball(lifted, light, centre, radius)
    unlifted = _ray_hits_ball(points, light, centre, radius)
    shown = dark.rgb.mean(axis=2) / np.maximum(lit.rgb.mean(axis=2), 1e-12)
    return {"occluded": 1.0 - shown[plane], "exact": exact[plane].astype(float), "xz": points[plane][:, [0, 2]],
            "unlifted": unlifted[plane].astype(float), "texel": texel, "elevation": float(np.arcsin(light[1]))}


def test_the_filtered_shadow_darkens_as_much_as_the_exact_one(sun_shadow_on_the_plane):
    """The filter's taps weigh a quarter each, so across an edge it averages as much light in as it
    lets out: summed over the plane's pixels, the occlusion (1 - visibility) equals the exact
    shadow's pixel count. Measured within 1% at 64 texels (bound 4%); a filter that lights a pixel
    when any of its taps is lit darkens 30% too little, one that darkens it unless all its taps are
    lit 56% too much."""
    d = sun_shadow_on_the_plane
    assert d["exact"].sum() > 500 and ((d["occluded"] > 0.02) & (d["occluded"] < 0.98)).mean() > 0.05  # penumbrae
    assert abs(d["occluded"].sum() / d["exact"].sum() - 1.0) < 0.04


def test_the_filtered_shadow_sits_where_the_exact_one_does(sun_shadow_on_the_plane):
    """The filter's taps sit symmetrically about the receiver (half a texel either way), so the
    shadow does not move: the occlusion's centroid on the plane equals the exact shadow's within
    0.2 shadow texels as seen by the light (a texel spans texel / sin(elevation) along the light's
    azimuth on the plane; measured 0.03). Taps shifted by half a texel move it by 0.59 texel; the
    exact shadow without the receiver's normal offset sits 0.8 texel away (the negative control:
    the offset is part of the expectation, and the check can tell the two apart)."""
    d = sun_shadow_on_the_plane
    xz = d["xz"]

    def centroid(weight: np.ndarray) -> np.ndarray:
        return (xz * weight[:, None]).sum(axis=0) / weight.sum()

    along = d["texel"] / np.sin(d["elevation"])  # a texel's footprint along the light's azimuth
    off = np.linalg.norm(centroid(d["occluded"]) - centroid(d["exact"])) / along
    assert off < 0.2, off
    assert np.linalg.norm(centroid(d["unlifted"]) - centroid(d["exact"])) > 0.5 * along  # the control


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
