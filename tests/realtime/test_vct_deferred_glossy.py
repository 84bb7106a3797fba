"""The deferred glossy read (vct_trace.glsl's vct_gloss_radiance): a cone reading a glossy surface gathers what the
surface reflects toward the cone, the environment taken about the mirror of the cone's own direction, not about
the directions of the six faces the voxels store.

A horizontal Phong plane (ks 0.8) alone under an environment whose radiance is linear in the direction,
L(w) = 1 + e . w (e the world direction of the map's +x: the map's +x column ramp, turned with the map). The
normalised Phong lobe P of exponent N about r has the first moment int P(l) l dl = k r, k = (N + 1) / (N + 2) (its
mean of r . l; the parts across r cancel), so it averages L to L_g(r) = 1 + k e . r. A cone looking down at the
plane along d, 40 degrees off the vertical toward +e and toward -e, sees r = reflect(d, +y) 40 degrees from the
zenith, the lobe wholly above the horizon (its share below is under 1e-9 for N = 50), so it gathers
ks (1 + k e . r) with e . r = +-sin 40 |e_h|. The two readings give the constant term (their mean, ks) and k.

A cone reads the mean over its directions and over the normals its texels stand for, so the lobe it reads is N's
convolved with the cone's directions (mean cosine (1 + cos a) / 2 for a cap of half-angle a) and the mirrors'
spread (2 l^2 - 1, l the stored normals' mean length: 1 on a plane): N' = vct_math.broadened_exponent, exact first
moment (N' + 1) / (N' + 2) (zonal convolutions multiply first moments; checked by sampling in test_vct_math.py).
The narrow cone's 5 degrees take N = 50 to N' = 45.4 and 500 to 255.

The store's chain stands in for the lobe with a box of texels at the level whose mean texel solid angle is the
lobe's 2 pi / (N' + 1) (McGuire et al.). A cube texel at a face's centre is 6 / pi times the mean, so a texel's
angular width a has a^2 <= 12 / (N' + 1); read trilinearly, the box's variance a^2 / 12 and the interpolation's
tent's a^2 / 6 per axis add a^2 / 2 of angular variance, which shrinks the first moment by a^2 / 4 (to first
order; the mip-linear blend with the next level blurs a little more). So k is about 1 - 3 / (N' + 1) at the least
and at most the exact lobe's (N' + 1) / (N' + 2): the band [1 - 3 / (N' + 1) - 0.005, (N' + 1) / (N' + 2) + 0.005]
([0.930, 0.984] for N = 50, [0.983, 1.001] for N = 500; measured 0.951 / 0.966 / 0.970 on the cube / dual
paraboloid / sphere map for N = 50, 0.989 / 0.994 / 0.993 for N = 500). So N = 500 tells a lost or wrong exponent
from the right one (N = 50's k is outside its band), which N = 50's band alone would not, and the band's upper
end tells a lobe read about the axis alone from the broadened one where the broadening is large: a wide cone
(25 degrees, N = 500: N' = 18.5, k at most 0.956, measured 0.858) and a plane whose stored spread is set to
l = 0.99 or 0.97 (stored 0.9896 and 0.9702: N' = 20.2 and 6.3, measured 0.867 and 0.702), where the
unbroadened lobe reads 0.99. Checked for each of the environment store's parameterizations (the read looks the
store up through its own uniforms), with the map turned 37 degrees (a swapped, negated or doubly applied turn
reads another direction), and with a cone wide enough to read the gloss texture's mips 3-4.

Under a constant environment a cone 80 degrees off the vertical sees r graze the plane (n . r = cos 80): the read
scales the lobe by its share above the horizon, vct_math.lobe_above_horizon (0.893 for N = 50, itself checked
against sampling the lobe), where the whole lobe would give 1.

The gloss texture's mips keep the exponent: alpha over the weight's mean is N at every level.

Controls: the six-face storage (`deferred_glossy=False`) stores in the +Y face the radiance toward +y,
ks L_g(+y) = ks, and reads it whichever way the cone looks: k = 0, and 1 at the grazing cone.
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
from realtime.engine.context import get_context
from realtime.engine.environment_maps import environment_store
from realtime.techniques.vct import vct_math
from realtime.techniques.vct.vct import VoxelScene
from scenes.environment import directions, envmap

pytestmark = pytest.mark.gl

KS = 0.8
TILT_DEG = 40.0
GRAZING_DEG = 80.0
#: narrow: the cone meets the plane within a few voxels of its axis, reading levels 0-1
NARROW = (math.tan(math.radians(5.0)), 0.6)
#: wide, from higher up: the cone's diameter at the plane is about 10 voxels (levels 3-4)
WIDE = (math.tan(math.radians(25.0)), 1.2)
GRID = vct_math.Cascades((0.0, 0.5 * 4.4 / 32, 0.0), 2.2, 32, 1)


@pytest.fixture(scope="module")
def linear_sky(tmp_path_factory) -> str:
    """An environment map of radiance 1 + w_x in every channel (w the pixel's direction in the map's frame)."""
    d = directions.equirect_directions(128, 256)
    path = tmp_path_factory.mktemp("env") / "linear_x.exr"
    envmap.write(path, np.repeat(1.0 + d[..., :1], 3, axis=-1).astype(np.float32))
    return str(path)


def voxels(overrides: dict, exponent: float, deferred: bool):
    """The Phong plane (ks 0.8, `exponent`) under the scene's environment with `overrides`, 32^3, one cascade;
    (VoxelScene, its environment store, the map's world +x direction e from the reference's own lookup)."""
    ctx = get_context()
    scene = scenes.load("builtin:sphere-on-plane").with_overrides(overrides)
    env = environment_store(ctx, scene)
    env.fill_base(scene.environment.rotation_deg)
    env.build_chain(None)
    env.project_sh(64)
    phong = dataclasses.replace(scenes.load("builtin:torus-phong").objects[0].material, ks=(KS,) * 3,
                                exponent=exponent)
    plane = SimpleNamespace(mesh=scene.objects[1].mesh, material=phong)
    vs = VoxelScene(ctx, [plane], 32, 1, 6, 0.5, grid=GRID, env_filter=env, deferred_glossy=deferred)
    vs.update(None, env.sh_buffer)
    assert vs.meta()["vct"]["glossy_read"] == ("deferred" if deferred else "six faces")
    radiance = np.asarray(scene.environment.radiance(), np.float64)
    axes = np.eye(3)
    e = (envmap.lookup(radiance, axes, scene.environment.rotation_deg)
         - envmap.lookup(radiance, -axes, scene.environment.rotation_deg))[:, 0] / 2.0
    return vs, env, e


def cone_reads(vs, dirs: np.ndarray, cone: tuple[float, float]) -> np.ndarray:
    """Grey radiance per unit opacity the cones along `dirs` gather from the plane, each from `cone`'s height
    above the plane's point at the origin."""
    tan_half, height = cone
    origins = height / -dirs[:, 1:2] * -dirs
    out = vs.trace_cone(origins, dirs, np.full(len(dirs), tan_half), np.zeros(len(dirs)), origins, dirs)
    assert (out[:, 3] > 0.99).all(), out  # the plane fills the cone
    return out[:, :3].mean(axis=1) / out[:, 3]


def constant_and_k(linear_sky: str, overrides: dict, exponent: float, deferred: bool,
                   cone: tuple[float, float], mean_length: float | None = None) -> tuple[float, float]:
    """The readings ks (1 + k e . r) of the cones tilted toward +e_h and -e_h, as (constant term / ks, k); with
    `mean_length`, every face normal's stored spread set to it (level 0, then the mips) before the reads."""
    vs, env, e = voxels({"environment.map": linear_sky, **overrides}, exponent, deferred)
    if mean_length is not None:
        normals = vs.read_normals(0)
        vs.write_level0(vs.read_faces(0), normals, np.full(normals.shape[:-1], mean_length))
        vs.build_mips()
    h = np.array([e[0], 0.0, e[2]])
    s, c = math.sin(math.radians(TILT_DEG)), math.cos(math.radians(TILT_DEG))
    toward = h / np.linalg.norm(h)
    dirs = np.array([s * toward - c * np.array([0.0, 1.0, 0.0]), -s * toward - c * np.array([0.0, 1.0, 0.0])])
    got = cone_reads(vs, dirs, cone)  # mirror directions r = (+-s toward, c)
    vs.release()
    env.release()
    return float(got.mean() / KS), float((got[0] - got[1]) / (2.0 * KS * s * np.linalg.norm(h)))


def k_band(exponent: float, cone: tuple[float, float], mean_length: float = 1.0) -> tuple[float, float]:
    """The first moment k of what the cone reads: the lobe broadened by the cone's aperture and the normals'
    spread, N' = vct_math.broadened_exponent(N, cap_mean_cos(tan a) (2 l^2 - 1)), whose exact first moment is
    mu' = (N' + 1) / (N' + 2); the chain stands in for it with k in [1 - 3 / (N' + 1), mu'] (the module's
    docstring), widened by 0.005."""
    spread = vct_math.cap_mean_cos(cone[0]) * vct_math.reflection_spread_mean_cos(mean_length)
    broadened = vct_math.broadened_exponent(exponent, spread)
    return 1.0 - 3.0 / (broadened + 1.0) - 0.005, (broadened + 1.0) / (broadened + 2.0) + 0.005


@pytest.mark.parametrize("parameterization", ["cube", "dual_paraboloid", "sphere_map"])
@pytest.mark.parametrize("exponent", [50.0, 500.0])
def test_a_cone_gathers_the_glossy_reflection_toward_itself(linear_sky, parameterization, exponent):
    constant, k = constant_and_k(linear_sky, {"realtime.parameterization": parameterization}, exponent, True,
                                 NARROW)
    low, high = k_band(exponent, NARROW)
    assert constant == pytest.approx(1.0, rel=0.01)
    assert low < k < high, (k, low, high)


@pytest.mark.parametrize("cone", [NARROW, WIDE], ids=["narrow", "wide"])
def test_the_read_looks_up_the_world_direction_of_a_turned_environment(linear_sky, cone):
    constant, k = constant_and_k(linear_sky, {"environment.rotation_deg": 37.0}, 50.0, True, cone)
    low, high = k_band(50.0, cone)
    assert constant == pytest.approx(1.0, rel=0.01)
    assert low < k < high, (k, low, high)


def test_a_wide_cone_reads_the_lobe_broadened_by_its_aperture(linear_sky):
    """A cone of 25 degrees reading an N = 500 plane gathers the lobe's mean over the cone's directions: k in the
    band of N' = broadened_exponent(500, (1 + cos 25 deg) / 2) = 18.5, at most its first moment 0.951 (the lobe
    about the axis alone reads 0.99, outside it)."""
    constant, k = constant_and_k(linear_sky, {}, 500.0, True, WIDE)
    low, high = k_band(500.0, WIDE)
    assert high < 0.96
    assert constant == pytest.approx(1.0, rel=0.01)
    assert low < k < high, (k, low, high)


@pytest.mark.parametrize("mean_length", [1.0, 0.99, 0.97])
def test_spread_normals_broaden_the_lobe_they_reflect(linear_sky, mean_length):
    """The plane's stored spread set to l (its faces then stand for normals of mean cosine l; stored as the byte
    round(255 sqrt(1 - l)): 0.98960 and 0.97023 for 0.99 and 0.97): the read takes the mirrors' spread, mean
    cosine 2 l^2 - 1 (0.959, 0.883), so k falls into the band of N' = broadened_exponent(500, 0.998 (2 l^2 - 1))
    (N' = 20.2, 6.3), at most 0.955 and 0.879. Control: l = 1 written the same way reads N = 500's band."""
    constant, k = constant_and_k(linear_sky, {}, 500.0, True, NARROW, mean_length)
    stored = 1.0 - (round(255.0 * math.sqrt(1.0 - mean_length)) / 255.0) ** 2
    low, high = k_band(500.0, NARROW, stored)
    assert constant == pytest.approx(1.0, rel=0.01)
    assert low < k < high, (k, low, high)
    if mean_length < 1.0:
        assert high < 0.97 < k_band(500.0, NARROW)[0]  # the bands of spread and unspread normals are apart


def test_control_the_six_face_storage_reads_the_stored_direction_both_ways(linear_sky):
    constant, k = constant_and_k(linear_sky, {}, 50.0, False, NARROW)
    assert constant == pytest.approx(1.0, rel=0.01)  # ks L_g(+y), stored in the +Y face
    assert abs(k) < 0.05


@pytest.mark.parametrize("deferred", [True, False], ids=["deferred", "six-faces-control"])
def test_a_grazing_read_takes_the_lobes_share_above_the_horizon(deferred):
    vs, env, _ = voxels({"environment.map": "builtin:constant"}, 50.0, deferred)
    s, c = math.sin(math.radians(GRAZING_DEG)), math.cos(math.radians(GRAZING_DEG))
    got = cone_reads(vs, np.array([[s, -c, 0.0], [0.0, -c, -s]]), (NARROW[0], 0.3)) / KS
    vs.release()
    env.release()
    share = vct_math.lobe_above_horizon(c, 50.0)
    assert share < 0.9  # the lobe grazes: its share is not 1
    if deferred:
        assert got == pytest.approx(np.full(2, share), abs=0.02)
    else:
        assert got == pytest.approx(np.full(2, 1.0), abs=0.02)  # the +Y face's lobe, wholly above its horizon


@pytest.mark.parametrize("exponent", [50.0, 500.0])
def test_the_gloss_mips_keep_the_exponent(exponent):
    vs, env, _ = voxels({"environment.map": "builtin:constant"}, exponent, True)
    levels = [vs.read_gloss(level) for level in (1, 2, 3)]
    vs.release()
    env.release()
    for gloss in levels:
        weight = gloss[..., :3].mean(axis=-1)
        held = weight > 1e-3
        assert held.sum() >= 4
        np.testing.assert_allclose(gloss[..., 3][held] / weight[held], exponent, rtol=0.01)


@pytest.mark.parametrize(("interreflection", "glossy_read", "expected", "bytes_per_voxel"), [
    (True, "deferred", "deferred", 128), (True, "six_faces", "six faces", 80), (False, "deferred", "six faces", 80)])
def test_the_frame_reads_gloss_deferred_where_interreflection_asks_for_it(interreflection, glossy_read, expected,
                                                                            bytes_per_voxel):
    """`[realtime.vct] glossy_read` chooses the read for a glossy scene; occlusion alone reads the cones' opacities
    only, so it stores no gloss (80 bytes a voxel: six RGBA16F faces, the RGBA16F columns, six RGBA8 normals; the
    gloss texture's six RGBA16F faces add 48)."""
    overrides = {"camera.width": 16, "camera.height": 16, "realtime.occlusion": "vct",
                 "realtime.vct.resolution": 16, "realtime.vct.cascades": 1, "realtime.vct.glossy_read": glossy_read,
                 "realtime.timing_frames": 1, "realtime.warmup_frames": 0}
    if interreflection:
        overrides["realtime.interreflection"] = "vct"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # occlusion alone: the interreflection the image leaves out
        render = realtime.render(scenes.load("builtin:torus-phong").with_overrides(overrides))
    assert render.meta["vct"]["glossy_read"] == expected
    assert render.meta["vct"]["bytes_per_voxel"] == bytes_per_voxel
    assert np.isfinite(render.rgb).all()
