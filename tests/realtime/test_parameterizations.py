"""The dual paraboloid and the sphere map through the whole real-time pipeline.

Independent expectations:
- the GPU's base level is the Mitsuba-convention lookup (scenes.environment.envmap) at every texel's direction
  (scenes/environment/paraboloid.py, scenes/environment/spheremap.py), its chain the 2x2 box mean computed here in
  numpy, its
  SH9 the numpy projection with exact texel solid angles, and close to the equirect map's own;
- a constant environment gives kd (diffuse) and ks (mirror, any LOD) on every parameterization;
- orientation: a map with one bright, marked direction lights a mirror sphere at the pixel the analytic
  reflection predicts, for all three parameterizations;
- the LOD rule is in solid angle: the level a lookup reads covers the solid angle of the cube's mean
  texel at the host's LOD (read back by storing each level's index in the level itself);
- the sphere map made for the render view matches the cube map on a mirror sphere away from its rim;
- a sphere map captured off-axis (a frame that is not its own transpose, written by hand) holds a marked
  direction at the texel the mirror ball formula gives; one captured along an oblique view matches the
  analytic reflections away from its rim;
- per-vertex reflection vectors on a coarse sphere err more than per-pixel ones.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import realtime
from realtime.engine import sh
from realtime.engine.context import get_context
from realtime.engine.environment_maps import MAPPINGS, MapShProjector, MapStore, environment_store, map_frame
from scenes.environment import cubemap, envmap
from scenes.environment.directions import equirect_directions
from scenes.environment.shbasis import sh9, sh_basis

from .test_render import analytic_sphere, small

pytestmark = pytest.mark.gl

PARAMS = ("cube", "dual_paraboloid", "sphere_map")


def reflections(scene):
    n, v, interior = analytic_sphere(scene)
    return 2.0 * np.sum(n * v, axis=-1, keepdims=True) * n - v, interior


def blob_environment(direction, sigma_deg: float = 4.0, h: int = 128, w: int = 256) -> np.ndarray:
    """A dim map with one bright Gaussian patch about `direction` (and a colour ramp to mark the axes)."""
    d = equirect_directions(h, w)
    c = np.asarray(direction, dtype=np.float64)
    c /= np.linalg.norm(c)
    angle = np.arccos(np.clip(d @ c, -1, 1))
    bright = 50.0 * np.exp(-0.5 * (angle / math.radians(sigma_deg)) ** 2)
    base = 0.05 + 0.02 * np.stack([1 + d[..., 0], 1 + d[..., 1], 1 + d[..., 2]], -1)
    return (base + bright[..., None]).astype(np.float32)


# ------------------------------------------------------------------------------ the store itself


@pytest.fixture(scope="module")
def probe_scene():
    return small("builtin:sphere-diffuse", **{"environment.rotation_deg": 30.0, "realtime.base_size": 32,
                                               "realtime.face_size": 16})


@pytest.mark.parametrize("name", list(MAPPINGS))
def test_fill_chain_and_sh_match_numpy(probe_scene, name):
    scene = probe_scene.with_overrides({"realtime.parameterization": name})
    mod = MAPPINGS[name]
    env = scene.environment.radiance()
    store = environment_store(get_context(), scene)
    try:
        assert store.size == mod.map_size(32) == 64
        store.fill_base(30.0)
        store.build_chain()
        world = mod.texel_directions(store.size) @ map_frame(scene)
        want = envmap.lookup(env, world, 30.0)
        base_level = store.read_level(0)
        np.testing.assert_allclose(base_level, want, rtol=1e-3)  # float32 (u, v) on the GPU
        level = base_level.astype(np.float64)
        for k in range(1, store.n_levels):
            level = cubemap.box_downsample(level).astype(np.float64)  # (layers, s, s, 3): the same 2x2 mean
            np.testing.assert_allclose(store.read_level(k), level, rtol=2e-5, atol=1e-6)
        # SH9 of the level holding face size 16 (side 32), with the parameterization's exact solid angles
        store.project_sh(16)
        coeffs, M = store.read_sh()
        lvl = store.read_level(1).astype(np.float64)
        d32 = mod.texel_directions(32) @ map_frame(scene)
        w32 = mod.texel_solid_angles(32)
        want_c = np.einsum("lijk,lij,lijc->kc", sh9(d32), w32, lvl)
        np.testing.assert_allclose(coeffs, want_c, rtol=1e-4, atol=1e-4 * np.abs(want_c).max())
        np.testing.assert_allclose(M, sh.irradiance_matrices(coeffs), rtol=1e-5, atol=1e-6)
        # and close to the equirect map's own projection (another quadrature of the same radiance)
        ref = sh.project_equirect(env, 30.0)
        assert np.abs(coeffs - ref).max() < 0.03 * np.abs(ref).max()
        # order 4 (realtime.sh_order) through the same texels
        projector = MapShProjector(get_context(), 4)
        try:
            projector.run(store, 1, 16)
            c4, weighted = projector.read()
        finally:
            projector.release()
        want4 = np.einsum("lijk,lij,lijc->kc", sh_basis(d32, 4), w32, lvl)
        np.testing.assert_allclose(c4, want4, rtol=1e-4, atol=1e-4 * np.abs(want4).max())
        np.testing.assert_allclose(c4[:9], coeffs, rtol=1e-4, atol=1e-4 * np.abs(want4).max())
    finally:
        store.release()


# ------------------------------------------------------------------------------ rendered images


@pytest.mark.parametrize("param", PARAMS[1:])
@pytest.mark.parametrize("reflection", ["per_pixel", "per_vertex"])
def test_constant_env_gives_kd_and_ks(param, reflection):
    common = {"environment.map": "builtin:constant", "realtime.parameterization": param,
              "realtime.reflection": reflection}
    for order in (2, 4):
        r = realtime.render(small("builtin:sphere-diffuse", **common, **{"objects.0.material.kd": [0.8, 0.5, 0.2],
                                                                         "realtime.sh_order": order}))
        np.testing.assert_allclose(r.rgb[r.mask], np.broadcast_to([0.8, 0.5, 0.2], r.rgb[r.mask].shape), atol=1e-3)
    for bias in (-2.0, 0.0, 3.0, 20.0):
        r = realtime.render(small("builtin:sphere-phong", **common, **{"realtime.lod_bias": bias,
                                                                       "objects.0.material.ks": [0.9, 0.6, 0.3]}))
        np.testing.assert_allclose(r.rgb[r.mask], np.broadcast_to([0.9, 0.6, 0.3], r.rgb[r.mask].shape),
                                   atol=1e-3)


def weighted_centroid(img: np.ndarray, sel: np.ndarray) -> np.ndarray:
    lum = img.mean(axis=-1)
    w = np.where(sel, np.maximum(lum - 0.1 * lum[sel].max(), 0.0), 0.0)
    rows, cols = np.indices(lum.shape)
    return np.array([(w * rows).sum(), (w * cols).sum()]) / w.sum()


@pytest.mark.parametrize("direction", [(1.0, 0.0, 0.0), (0.5, 0.6, 0.62), (-0.69, 0.62, -0.41)],
                         ids=["+X", "up-right-front", "up-left-back"])
def test_a_marked_direction_lights_the_same_pixel_on_every_parameterization(tmp_path, direction):
    path = tmp_path / "blob.exr"
    envmap.write(path, blob_environment(direction))
    centroids = {}
    for param in PARAMS:
        scene = small("builtin:sphere-phong", **{"environment.map": str(path), "realtime.parameterization": param,
                                                  "realtime.base_size": 128, "realtime.face_size": 128,
                                                  "objects.0.material.exponent": 1e6})
        r = realtime.render(scene)
        refl, interior = reflections(scene)
        sel = interior & r.mask
        expected = envmap.lookup(scene.environment.radiance(), refl)  # the analytic reflection
        want = weighted_centroid(expected, sel)
        centroids[param] = got = weighted_centroid(r.rgb, sel)
        assert np.linalg.norm(got - want) < 0.75, (param, got, want)
    assert np.linalg.norm(centroids["dual_paraboloid"] - centroids["cube"]) < 0.75
    assert np.linalg.norm(centroids["sphere_map"] - centroids["cube"]) < 0.75


# A sphere map captured along (1, 0, -1) with the camera's up (+y). By hand, the world -> map rotation has
# the rows right = (1, 0, 1) / sqrt 2, up = +y, back = (-1, 0, 1) / sqrt 2: a 45 degree turn about y that
# differs from its transpose, so a store or a shader that applies the inverse frame puts things elsewhere.
OFF_AXIS = [1.0, 0.0, -1.0]
OFF_AXIS_FRAME = np.array([[1.0, 0.0, 1.0], [0.0, math.sqrt(2.0), 0.0], [-1.0, 0.0, 1.0]]) / math.sqrt(2.0)
#: the marked direction: 55 degrees from the capture's back axis, seen head-on from the render camera
MARK = np.array([0.0, 0.6, 0.8])


def mirror_ball_texel(d_map: np.ndarray, size: int) -> np.ndarray:
    """(row, column) in texel units (texel centres at integers) of a map-frame direction on a sphere map
    of side `size`: the mirror ball's normal there is the half vector of d and the viewer's +z, and the
    map position is that normal's (x, y); row 0 at y = -1."""
    h = d_map + np.array([0.0, 0.0, 1.0])
    x, y = h[:2] / np.linalg.norm(h)
    return np.array([(y + 1) / 2 * size - 0.5, (x + 1) / 2 * size - 0.5])


def test_off_axis_sphere_map_holds_the_mark_where_the_mirror_ball_puts_it(tmp_path):
    """The GPU fill of a sphere map captured off-axis: the bright mark's centroid is at the texel the mirror
    ball formula gives for the hand-made frame (within 0.75 texel), far from where the inverse frame puts it."""
    path = tmp_path / "mark.exr"
    envmap.write(path, blob_environment(MARK, sigma_deg=3.0))
    scene = small("builtin:sphere-phong", **{"environment.map": str(path), "realtime.parameterization": "sphere_map",
                                              "realtime.sphere_map.capture": OFF_AXIS, "realtime.base_size": 64})
    np.testing.assert_allclose(map_frame(scene), OFF_AXIS_FRAME, atol=1e-15)
    store = environment_store(get_context(), scene)
    try:
        store.fill_base(scene.environment.rotation_deg)
        level = store.read_level(0)[0]
    finally:
        store.release()
    size = level.shape[0]
    got = weighted_centroid(level, np.ones(level.shape[:2], bool))
    want = mirror_ball_texel(OFF_AXIS_FRAME @ MARK, size)
    wrong = mirror_ball_texel(OFF_AXIS_FRAME.T @ MARK, size)
    assert np.linalg.norm(want - wrong) > 10  # the inverse frame moves the mark by tens of texels
    assert np.linalg.norm(got - want) < 0.75, (got, want, wrong)


def test_sphere_map_made_for_the_render_view_matches_the_cube_away_from_its_rim():
    common = {"realtime.base_size": 128, "realtime.face_size": 128, "objects.0.material.exponent": 1e6}
    cube = realtime.render(small("builtin:sphere-phong", **common))
    smap = realtime.render(small("builtin:sphere-phong", **common, **{"realtime.parameterization": "sphere_map"}))
    scene = small("builtin:sphere-phong", **common)
    refl, interior = reflections(scene)
    view = np.subtract(scene.camera.target, scene.camera.origin)
    view /= np.linalg.norm(view)
    # away from the rim: reflections within 120 degrees of the direction back at the viewer (rho < 0.87)
    sel = interior & cube.mask & smap.mask & (refl @ -view > math.cos(math.radians(120)))
    assert sel.sum() > 1000
    expected = envmap.lookup(scene.environment.radiance(), refl)
    for img in (cube.rgb, smap.rgb):
        rel = np.abs(img[sel] - expected[sel]).mean(-1) / (expected[sel].mean(-1) + 1e-3)
        assert np.median(rel) < 0.03
    rel = np.abs(smap.rgb[sel] - cube.rgb[sel]).mean(-1) / (cube.rgb[sel].mean(-1) + 1e-3)
    assert np.median(rel) < 0.03 and np.percentile(rel, 90) < 0.15
    # a fixed capture direction equal to the camera's view gives the same map
    fixed = realtime.render(small("builtin:sphere-phong", **common, **{
        "realtime.parameterization": "sphere_map", "realtime.sphere_map.capture": list(view)}))
    np.testing.assert_array_equal(fixed.rgb, smap.rgb)


def test_sphere_map_captured_along_an_oblique_view_matches_the_analytic_reflection():
    """A sphere map captured along a direction c tilted ~45 degrees off the render view (neither an axis
    nor the camera's own view, whose frames are symmetric matrices: a transposed frame would go unseen)
    still shows every mirror reflection r of the render: away from the map's rim (r within 120 degrees of
    -c), the image is the Mitsuba-convention lookup of the map at the analytic r (median 0.2 % measured,
    the same bound as the camera-captured map above). Negative control: a frame R used transposed, in the
    lookup (reads R^T R^T r) or in the texels' directions (R R r), moves the image by ~70 %."""
    capture = np.array([0.6, 0.35, -0.7])
    capture /= np.linalg.norm(capture)
    scene = small("builtin:sphere-phong", **{"realtime.base_size": 128, "realtime.face_size": 128,
                                              "objects.0.material.exponent": 1e6,
                                              "realtime.parameterization": "sphere_map",
                                              "realtime.sphere_map.capture": list(capture)})
    r = realtime.render(scene)
    refl, interior = reflections(scene)
    sel = interior & r.mask & (refl @ capture < math.cos(math.radians(60)))
    assert sel.sum() > 1000
    env = scene.environment.radiance()
    expected = envmap.lookup(env, refl)

    def median_rel(img: np.ndarray) -> float:
        return float(np.median(np.abs(img[sel] - expected[sel]).mean(-1) / (expected[sel].mean(-1) + 1e-3)))

    assert median_rel(r.rgb) < 0.03
    # gluLookAt's eye space by hand (rows: right, true up, -c): the world -> map rotation R
    right = np.cross(capture, scene.camera.up)
    right /= np.linalg.norm(right)
    frame = np.stack([right, np.cross(right, capture), -capture])
    for wrong in (refl @ frame @ frame, refl @ frame.T @ frame.T):  # rows: R^T R^T r, R R r
        assert median_rel(envmap.lookup(env, wrong)) > 10 * 0.03


def test_sphere_map_seen_from_behind_puts_its_singularity_on_the_sphere():
    # captured looking the other way, the render view's central reflections sit on the map's rim
    common = {"realtime.base_size": 64, "realtime.face_size": 64, "objects.0.material.exponent": 1e6,
              "realtime.parameterization": "sphere_map"}
    scene = small("builtin:sphere-phong", **common)
    n, v, interior = analytic_sphere(scene)
    refl, _ = reflections(scene)
    expected = envmap.lookup(scene.environment.radiance(), refl)
    centre = interior & (np.sum(n * v, axis=-1) > 0.95)  # reflections within ~36 degrees of the view
    errors = []
    for capture in ("camera", [0.0, 0.0, 1.0]):
        r = realtime.render(small("builtin:sphere-phong", **common, **{"realtime.sphere_map.capture": capture}))
        sel = centre & r.mask
        errors.append(np.abs(r.rgb[sel] - expected[sel]).mean() / expected[sel].mean())
    assert errors[1] > 3 * errors[0]


def test_per_vertex_reflection_errs_more_than_per_pixel_on_a_coarse_sphere():
    errors = {}
    for reflection in ("per_pixel", "per_vertex"):
        scene = small("builtin:sphere-phong", **{"objects.*.resolution": 12, "realtime.reflection": reflection,
                                                  "realtime.face_size": 128, "realtime.base_size": 128,
                                                  "objects.0.material.exponent": 1e6})
        r = realtime.render(scene)
        refl, interior = reflections(scene)
        sel = interior & r.mask
        expected = envmap.lookup(scene.environment.radiance(), refl)
        errors[reflection] = np.abs(r.rgb[sel] - expected[sel]).mean() / expected[sel].mean()
        assert ("REFLECTION_PER_VERTEX" in r.meta["defines"]) == (reflection == "per_vertex")
    assert errors["per_vertex"] > 1.3 * errors["per_pixel"]


# ------------------------------------------------------------------------------ the LOD rule


LEVEL_INDEX_SHADER = """
#version 430
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 0) uniform writeonly image2DArray dst;
uniform int size;
uniform float value;
void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    if (g.x >= size || g.y >= size) return;
    imageStore(dst, g, vec4(value, value, value, 1.0));
}
"""


@pytest.mark.parametrize("name", list(MAPPINGS))
@pytest.mark.parametrize("bias", [0.0, 1.5])
def test_the_lookup_reads_the_level_of_equal_solid_angle(name, bias):
    from realtime.engine.gpu import SceneDrawer
    from realtime.engine.technique import Frame, build

    base, face = 64, 16
    scene = small("builtin:sphere-phong", **{"realtime.parameterization": name, "realtime.base_size": base,
                                              "realtime.face_size": face, "realtime.lod_bias": bias,
                                              "objects.0.material.ks": [1.0, 1.0, 1.0]})
    ctx = get_context()
    mod = MAPPINGS[name]
    store = MapStore(ctx, scene.environment.radiance(), base, mod, map_frame(scene))
    prog = ctx.compute_shader(LEVEL_INDEX_SHADER)
    drawer = None
    try:
        for level in range(store.n_levels):  # every texel of level k holds k: the image is the LOD read
            size = store.size >> level
            store.texture.bind_to_image(0, read=False, write=True, level=level)
            prog["size"], prog["value"] = size, float(level)
            prog.run((size + 7) // 8, (size + 7) // 8, store.layers)
        ctx.memory_barrier()
        host_lod = math.log2(base / face) + bias  # the paper's mapping: level(s) + bias
        glossy = build("glossy", "box", Frame(ctx, scene, store, face, int(math.log2(base / face))))
        drawer = SceneDrawer(ctx, scene, store, [glossy])
        drawer.draw_background(0.0)
        drawer.draw()
        rgb, mask = drawer.read()
    finally:
        if drawer is not None:
            drawer.release()
        prog.release()
        store.release()
    refl, interior = reflections(scene)
    _, x, y = mod.direction_to_position(refl @ map_frame(scene).T)
    # the level L whose texel at (x, y) covers the cube's mean texel solid angle at host_lod:
    # dOmega/dA(x, y) (2 / m)^2 4^L = 4 pi / (6 base^2) 4^host_lod, m = the map's side
    m = mod.map_size(base)
    omega_cube = 4 * math.pi / (6 * base**2) * 4**host_lod
    want = np.clip(0.5 * np.log2(omega_cube / (mod.density(x, y) * (2.0 / m) ** 2)), 0, math.log2(m))
    sel = interior & mask
    np.testing.assert_allclose(rgb[sel][:, 0], want[sel], atol=0.02)
    if name == "dual_paraboloid":  # the level varies by log2(4) / 2 = 1 between the centre and the rim
        assert np.ptp(want[sel]) > 0.5
