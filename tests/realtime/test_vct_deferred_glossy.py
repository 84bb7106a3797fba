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

On the cube store, below the broad-lobe table's top exponent (127, realtime/techniques/vct/lobe_table.py), the read
is the lobe's integral itself, so k is the exact first moment (N' + 1) / (N' + 2): checked within 0.002. Above it,
and on the 2D stores always, the store's chain stands in for the lobe with a box of texels at the level whose mean
texel solid angle is the lobe's 2 pi / (N' + 1) (McGuire et al.), read trilinearly: it blurs the lobe, so its k is
below the exact lobe's, by how much depending on where r falls among the texels (N = 500's N' = 255 reads 0.976 on
the cube's weighted chain). So each cone's k is also checked against the store's own read of the broadened lobe
along the same two mirrors (VoxelScene.read_environment: vct_glossy_env.glsl bound as the cones bind it): within
0.002, and below the exact lobe's first moment where the chain reads. What that tells apart, each checked: a
wrong exponent (N = 10's broadened lobe, N' = 9.8, k 0.917 on the cube); a lobe read about the axis alone from
the broadened one where the broadening is large: a wide cone (25 degrees, N = 500: N' = 18.5, k 0.951 where the
lobe about the axis, read by the chain, gives 0.986) and a plane whose stored spread is set to l = 0.99 or 0.97
(stored 0.9896 and 0.9702: N' = 20.2 and 6.3, k 0.955 and 0.879) where the unspread lobe reads 0.976. Checked for
each of the environment store's parameterizations (the read looks the store up through its own uniforms), with
the map turned 37 degrees (a swapped, negated or doubly applied turn reads another direction), and with a cone
wide enough to read the gloss texture's mips 3-4.

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
from realtime.engine.environment_maps import filled_store
from realtime.techniques.vct import lobe_table, vct_math
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
#: the cones' k against the store's own read along the same mirrors, and against the exact first moment where the
#: broad-lobe table reads
K_TOLERANCE = 0.002
#: how far apart the store's reads of the right and a wrong lobe must be for the check to tell them apart
APART = 0.01


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
    env = filled_store(ctx, scene)
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


def store_reads(vs, mirrors: np.ndarray, exponent: float) -> np.ndarray:
    """The store read directly, as the cones read it (`VoxelScene.read_environment`: the broad-lobe table or the
    chain), along two `mirrors` for a Phong lobe of `exponent`: grey (2,)."""
    return vs.read_environment(mirrors, np.full(len(mirrors), exponent)).mean(axis=1)


@dataclasses.dataclass(frozen=True)
class Reading:
    """The cones' readings ks (1 + k e . r) toward +e_h and -e_h as (constant term / ks, k), and the k of the
    store read directly along the same mirrors for each exponent asked for."""
    constant: float
    k: float
    store_k: dict[float, float]


def constant_and_k(linear_sky: str, overrides: dict, exponent: float, deferred: bool,
                   cone: tuple[float, float], mean_length: float | None = None,
                   read_exponents: tuple[float, ...] = ()) -> Reading:
    """The cones tilted toward +e_h and -e_h read the plane (with `mean_length`, every face normal's stored spread
    set to it, level 0, then the mips, before the reads); the store read directly at each of `read_exponents`."""
    vs, env, e = voxels({"environment.map": linear_sky, **overrides}, exponent, deferred)
    if mean_length is not None:
        normals = vs.read_normals(0)
        vs.write_level0(vs.read_faces(0), normals, np.full(normals.shape[:-1], mean_length))
        vs.build_mips()
    h = np.array([e[0], 0.0, e[2]])
    s, c = math.sin(math.radians(TILT_DEG)), math.cos(math.radians(TILT_DEG))
    toward = h / np.linalg.norm(h)
    up = np.array([0.0, 1.0, 0.0])
    dirs = np.array([s * toward - c * up, -s * toward - c * up])
    got = cone_reads(vs, dirs, cone)  # mirror directions r = (+-s toward, c)
    mirrors = dirs * np.array([1.0, -1.0, 1.0])
    scale = 2.0 * s * np.linalg.norm(h)
    store_k = {}
    for n in read_exponents:
        read = store_reads(vs, mirrors, n)
        store_k[n] = float((read[0] - read[1]) / scale)
    vs.release()
    env.release()
    return Reading(float(got.mean() / KS), float((got[0] - got[1]) / (KS * scale)), store_k)


def broadened(exponent: float, cone: tuple[float, float], mean_length: float = 1.0) -> float:
    """N' = vct_math.broadened_exponent(N, cap_mean_cos(tan a) (2 l^2 - 1)): the lobe a cone of `cone`'s aperture
    reads off normals of mean cosine `mean_length`, whose exact first moment is (N' + 1) / (N' + 2)."""
    spread = vct_math.cap_mean_cos(cone[0]) * vct_math.reflection_spread_mean_cos(mean_length)
    return vct_math.broadened_exponent(exponent, spread)


def exact_k(exponent: float) -> float:
    """The normalised Phong lobe's first moment (N + 1) / (N + 2): what the chain's box of texels can only blur."""
    return (exponent + 1.0) / (exponent + 2.0)


def assert_k(r: Reading, right: float, parameterization: str = "cube") -> None:
    """The cones' k is the store's own read of the lobe N' = `right`: on the cube below the broad-lobe table's top
    exponent the exact first moment, otherwise the chain's blur, below it."""
    assert r.k == pytest.approx(r.store_k[right], abs=K_TOLERANCE)
    if parameterization == "cube" and right < lobe_table.TOP_EXPONENT:
        assert r.k == pytest.approx(exact_k(right), abs=K_TOLERANCE)
    else:
        assert r.k < exact_k(right) + K_TOLERANCE


@pytest.mark.parametrize("parameterization", ["cube", "dual_paraboloid", "sphere_map"])
@pytest.mark.parametrize("exponent", [50.0, 500.0])
def test_a_cone_gathers_the_glossy_reflection_toward_itself(linear_sky, parameterization, exponent):
    """k is the store's own read of the broadened lobe along the cone's mirror direction: on the cube below the
    broad-lobe table's top exponent the lobe's integral, so the exact first moment; otherwise the chain's, below
    it. A lobe read with a wrong exponent (N = 10's, N' = 9.8, k 0.917) would be told apart."""
    right, wrong = broadened(exponent, NARROW), broadened(10.0, NARROW)
    r = constant_and_k(linear_sky, {"realtime.parameterization": parameterization}, exponent, True, NARROW,
                       read_exponents=(right, wrong))
    assert r.constant == pytest.approx(1.0, rel=0.01)
    assert_k(r, right, parameterization)
    assert abs(r.store_k[wrong] - r.store_k[right]) > APART  # the exponents' reads are apart


@pytest.mark.parametrize("cone", [NARROW, WIDE], ids=["narrow", "wide"])
def test_the_read_looks_up_the_world_direction_of_a_turned_environment(linear_sky, cone):
    right = broadened(50.0, cone)
    r = constant_and_k(linear_sky, {"environment.rotation_deg": 37.0}, 50.0, True, cone, read_exponents=(right,))
    assert r.constant == pytest.approx(1.0, rel=0.01)
    assert_k(r, right)


def test_a_wide_cone_reads_the_lobe_broadened_by_its_aperture(linear_sky):
    """A cone of 25 degrees reading an N = 500 plane gathers the lobe's mean over the cone's directions, N' =
    broadened_exponent(500, (1 + cos 25 deg) / 2) = 18.5, first moment 0.951 (the broad-lobe table's read); the
    chain's read of the lobe about the axis alone (N = 500) is far above it."""
    right = broadened(500.0, WIDE)
    r = constant_and_k(linear_sky, {}, 500.0, True, WIDE, read_exponents=(right, 500.0))
    assert exact_k(right) < 0.96
    assert r.constant == pytest.approx(1.0, rel=0.01)
    assert_k(r, right)
    assert r.store_k[500.0] > r.k + APART


@pytest.mark.parametrize("mean_length", [1.0, 0.99, 0.97])
def test_spread_normals_broaden_the_lobe_they_reflect(linear_sky, mean_length):
    """The plane's stored spread set to l (its faces then stand for normals of mean cosine l; stored as the byte
    round(255 sqrt(1 - l)): 0.98960 and 0.97023 for 0.99 and 0.97): the read takes the mirrors' spread, mean
    cosine 2 l^2 - 1 (0.959, 0.883), so k is the store's read at N' = broadened_exponent(500, 0.998 (2 l^2 - 1))
    (N' = 20.2, 6.3): the broad-lobe table's, first moment 0.955 and 0.879. Control: l = 1 written the same way
    reads N = 500's broadened lobe (N' = 255), and the spread normals' k is far below that lobe's read."""
    stored = 1.0 - (round(255.0 * math.sqrt(1.0 - mean_length)) / 255.0) ** 2
    right, unspread = broadened(500.0, NARROW, stored), broadened(500.0, NARROW)
    r = constant_and_k(linear_sky, {}, 500.0, True, NARROW, mean_length, read_exponents=(right, unspread))
    assert r.constant == pytest.approx(1.0, rel=0.01)
    assert_k(r, right)
    if mean_length < 1.0:
        assert r.store_k[unspread] > r.k + APART


def test_control_the_six_face_storage_reads_the_stored_direction_both_ways(linear_sky):
    r = constant_and_k(linear_sky, {}, 50.0, False, NARROW)
    assert r.constant == pytest.approx(1.0, rel=0.01)  # ks L_g(+y), stored in the +Y face
    assert abs(r.k) < 0.05


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
