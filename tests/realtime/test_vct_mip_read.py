"""What a cone reads from a lit curved wall through the anisotropic mips (realtime/techniques/vct/vct_mip.comp,
vct_trace.glsl's vct_front), against expectations found independently:

- the mip's radiance is normalised by the opacity of its pairs that are not a surface's back: a 2x2x2 block
  whose four columns show a lit front on two and a back (black, lit the other way) on the other two reads
  the front's radiance at the block's opacity; a block of backs stays black; a block dark both ways stays
  black and opaque; a half-empty block keeps the plain average (hand-computed values);
- inside a bowl whose every lit face shows radiance L, a cone whose every direction meets the inside (the
  exact occlusion, ray-cast against the sphere here) gathers L times its opacity, at 32^3, 64^3, 128^3;
- with the bowl's outer wall at 2 L, the same cones still read L (not the wall's other side);
- two fronts of different radiance (no back on either axis) keep their d_a^2 weights (hand-computed).
Each check has a negative control: the mip's plain average, the binary front rule, the brightest face as
the radiance's reference, the dimmer of two fronts discounted: the same check rejects each.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import scenes
from realtime.engine.context import get_context
from realtime.engine.gpu import expand_includes, shader_source
from realtime.techniques.vct import vct_math
from realtime.techniques.vct.vct import NORMAL_OFFSET_VOXELS, START_OFFSET_VOXELS, VoxelScene
from scenes.geometry.meshes import BOWL_INNER, BOWL_OUTER, bowl_centre
from tests.helpers import scene_voxels

pytestmark = pytest.mark.gl

PACKAGE = "realtime.techniques.vct"
BOWL_CENTRE = bowl_centre()  # bowl-diffuse's two hemispheres, BOWL_INNER and BOWL_OUTER, about it
# the variants the negative controls compile: (shader, original text, replacement)
CONTROLS = {
    # every pair averaged as it is (no pair is a back)
    "mip_average": ("vct_mip.comp", "#define MIP_BACK_RATIO 1e-3", "#define MIP_BACK_RATIO -1.0"),
    # a face lit both ways counts whole in the radiance's normalisation
    "front_binary": ("vct_cone.comp", "return rho_ref > 0.0 ? clamp(vct_rho(against) / rho_ref, 0.0, 1.0) : 1.0;",
                     "return 1.0;"),
    # the radiance's reference is the brightest face read, not the dominant one
    "rho_brightest": ("vct_cone.comp",
                      "float rho_ref = wa.x >= wa.y && wa.x >= wa.z ? vct_rho(x)"
                      " : (wa.y >= wa.z ? vct_rho(y) : vct_rho(z));",
                      "float rho_ref = max(vct_rho(x), max(vct_rho(y), vct_rho(z)));"),
}


@pytest.fixture(scope="module")
def ctx():

    return get_context()


def variant(ctx, name: str):
    """(shader file, compiled program) of a negative control."""
    shader, old, new = CONTROLS[name]
    src = shader_source(shader, package=PACKAGE)
    if old not in src:
        raise AssertionError(f"control {name}: {old!r} is no longer in {shader}")
    return shader, ctx.compute_shader(src.replace(old, new))


def apply_control(ctx, vs, control: str | None) -> None:
    if control is None:
        return
    shader, prog = variant(ctx, control)
    if shader == "vct_mip.comp":
        vs.mip_prog = prog
    else:
        vs.cone_prog = prog


# -- the mip on hand-built blocks ------------------------------------------------------------------------

def block_faces(res: int, L: float) -> np.ndarray:
    """Level 0 (6, 1, res, res, res, 4): four 2x2x2 blocks along x, each of two columns pairs along x per
    (y, z). Block 0: columns y = 0 a front toward +X (its +X face lit L, -X black), y = 1 a surface facing -X
    (+X black, -X lit): from +X two fronts and two backs. Block 1: a thin wall's dark side toward +X (every
    column +X black, -X lit). Block 2: dark both ways. Block 3: columns y = 0 lit toward +X, y = 1 empty.
    Block 4 (y = 2, 3): a back behind a dark surface, below."""
    f = np.zeros((6, 1, res, res, res, 4), "f4")
    lit, black = [L, L, L, 1.0], [0.0, 0.0, 0.0, 1.0]
    f[0, 0, 1, 0, 0:2], f[1, 0, 1, 0, 0:2] = lit, black
    f[0, 0, 1, 1, 0:2], f[1, 0, 1, 1, 0:2] = black, lit
    f[0, 0, 3, 0:2, 0:2], f[1, 0, 3, 0:2, 0:2] = black, lit
    f[0, 0, 5, 0:2, 0:2], f[1, 0, 5, 0:2, 0:2] = black, black
    f[0, 0, 7, 0, 0:2], f[1, 0, 7, 0, 0:2] = lit, black
    # block 4 (level-1 texel (0, 1, 0)): columns y = 2 a front toward +X; columns y = 3 a surface facing -X
    # (x = 1) behind a surface dark both ways (x = 0): from -X the dark one hides the lit one, so from +X the
    # column is black both ways (a dark surface), not a back
    f[0, 0, 1, 2, 0:2], f[1, 0, 1, 2, 0:2] = lit, black
    f[0, 0, 0, 3, 0:2], f[1, 0, 0, 3, 0:2] = black, black
    f[0, 0, 1, 3, 0:2], f[1, 0, 1, 3, 0:2] = black, lit
    return f


# (block, face) -> level-1 (rgb, alpha) by hand: a front pair is (L, 1), a back pair (0, 1), an empty one (0, 0);
# alpha is the pairs' mean, rgb the lit pairs' sum over the non-back pairs' opacity, times alpha
BLOCK_EXPECTED = {
    (0, 0): (1.0, 1.0),  # two fronts, two backs: L at opacity 1 (the plain mean would give L / 2)
    (0, 1): (1.0, 1.0),  # the same block from -X: the other two columns are the fronts
    (1, 0): (0.0, 1.0),  # a thin wall's dark side: backs only, black
    (1, 1): (1.0, 1.0),  # its lit side
    (2, 0): (0.0, 1.0),  # dark both ways: black and opaque
    (3, 0): (0.5, 0.5),  # half empty, no back: the plain mean
    (4, 0): (0.5, 1.0),  # two fronts, two columns dark both ways (the opposite pair composited front to back)
}
# (block, face) -> the level-1 texel's (x, y, z)
BLOCK_TEXEL = {0: (0, 0, 0), 1: (1, 0, 0), 2: (2, 0, 0), 3: (3, 0, 0), 4: (0, 1, 0)}


def blank_voxels(ctx, res: int):

    plane = scenes.load("builtin:sphere-on-plane").objects[1]
    return VoxelScene(ctx, [plane], res, 1, 6, 0.5, grid=vct_math.Cascades((0.0, 0.0, 0.0), 1.0, res, 1))


@pytest.mark.parametrize("control", [None, "mip_average"])
def test_mip_normalises_radiance_by_the_opacity_of_its_fronts(ctx, control):
    L = 0.6
    vs = blank_voxels(ctx, 8)
    apply_control(ctx, vs, control)
    vs.write_level0(block_faces(8, L))
    vs.build_mips()
    level1 = vs.read_faces(1)[:, 0]
    vs.release()
    got = {(block, face): (float(level1[(face, *BLOCK_TEXEL[block])][:3].mean()) / L,
                           float(level1[(face, *BLOCK_TEXEL[block])][3]))
           for block, face in BLOCK_EXPECTED}
    ok = all(got[k] == pytest.approx(v, abs=2e-3) for k, v in BLOCK_EXPECTED.items())
    assert ok == (control is None), got


# -- cones inside the lit bowl ----------------------------------------------------------------------------

def exact_occlusion(x: np.ndarray, d: np.ndarray, half_angle: float, rng: np.random.Generator) -> float:
    """The share of the cone's directions (uniform in solid angle) from x, inside the bowl's sphere, whose
    ray meets the sphere below the rim (y < centre): the far root of |x + t w - c| = R."""
    w = vct_math.cap_directions(d[None], half_angle, 4000, rng)[0]
    o = x - BOWL_CENTRE
    b, c = w @ o, o @ o - BOWL_INNER ** 2
    t = -b + np.sqrt(np.maximum(b * b - c, 0.0))
    return float((o[1] + t * w[:, 1] < 0.0).mean())


def lit_bowl(ctx, res: int, outer_radiance: float, control: str | None):
    """bowl-diffuse voxelised and injected, then every lit face set to radiance 1 (times its coverage,
    premultiplied), the outer wall's (voxel centres beyond the wall's mid-radius) to `outer_radiance`."""

    vs = scene_voxels(ctx, scenes.load("builtin:bowl-diffuse"), res)
    apply_control(ctx, vs, control)
    f = vs.read_faces(0)
    g = vs.grid
    centres = np.asarray(g.centre) - g.half_extent + (np.indices((res,) * 3).transpose(1, 2, 3, 0) + 0.5) * g.voxel_size
    outer = np.linalg.norm(centres - BOWL_CENTRE, axis=-1) > 0.5 * (BOWL_INNER + BOWL_OUTER)
    radiance = np.where(outer, outer_radiance, 1.0)[None, None, ..., None]
    lit = f[..., :3].max(-1) > 0.0
    f[..., :3] = np.where(lit[..., None], radiance * f[..., 3:4], 0.0)
    vs.write_level0(f.astype("f4"), vs.read_normals(0))
    vs.build_mips()
    return vs


#: the directions the blocked cones are drawn from, in the normal's frame: one along it and five in a ring 60
#: degrees from it (a ring of six cones' aperture that reaches 3.6 degrees below the horizon, so that at every
#: point below a rim one of them, down the wall, meets the inside with all its directions; the shading's own ring,
#: vct_math.cone_set, stays above the horizon, and only 3 of its 54 cones at these points are fully blocked)
RING_DIRECTIONS = vct_math.ring_directions(6, 0.5)


def blocked_cones(vs) -> np.ndarray:
    """Cones of the six diffuse cones' aperture along RING_DIRECTIONS at inner points 40, 55, 75 degrees from the
    bottom (three azimuths) whose every direction meets the inside: (radiance gathered, occlusion) per cone."""

    cones = vct_math.cone_set(6)
    rng = np.random.default_rng(1)
    h = vs.grid.voxel_size
    rows = []
    for theta in np.radians([40.0, 55.0, 75.0]):
        for phi in (0.3, 1.2, 2.5):
            u = np.array([math.sin(theta) * math.sin(phi), -math.cos(theta), math.sin(theta) * math.cos(phi)])
            x, n = BOWL_CENTRE + BOWL_INNER * u, -u
            for d in RING_DIRECTIONS @ vct_math.tangent_frame(n):
                if exact_occlusion(x, d, cones.half_angle, rng) > 0.999:
                    rows.append((x + NORMAL_OFFSET_VOXELS * h * n, d, x, n))
    o, d, x, n = (np.array(c) for c in zip(*rows, strict=True))
    k = len(rows)
    return vs.trace_cone(o, d, np.full(k, math.tan(cones.half_angle)), np.full(k, START_OFFSET_VOXELS * h), x, n)


def reads_the_wall(r: np.ndarray, L: float = 1.0) -> bool:
    """Every blocked cone opaque (> 0.99) and its radiance over its opacity within [0.96, 1.03] of L."""
    ratio = r[:, :3].mean(1) / np.maximum(r[:, 3], 1e-9) / L
    return bool((r[:, 3] > 0.99).all() and ((ratio > 0.96) & (ratio < 1.03)).all())


@pytest.mark.parametrize(("res", "control"), [
    (32, None), (64, None), pytest.param(128, None, marks=pytest.mark.slow),
    (32, "front_binary"), (64, "mip_average"), (64, "front_binary"),
    pytest.param(128, "mip_average", marks=pytest.mark.slow)])
def test_cone_inside_a_uniformly_lit_bowl_reads_its_radiance(ctx, res, control):
    """The worst of the blocked cones reads 1.000 / 0.968 / 0.979 of L at 32^3 / 64^3 / 128^3 (before both rules:
    0.90 / 0.80 / 0.57); with the binary front rule 0.90 / 0.82 / 0.84, with the mip's plain average 1.00 / 0.95 /
    0.58 (the read's share carries 32^3 and 64^3, the mip's back rule 128^3)."""
    vs = lit_bowl(ctx, res, 1.0, control)
    r = blocked_cones(vs)
    vs.release()
    assert len(r) >= 9  # the down-the-wall cone at every point
    assert reads_the_wall(r) == (control is None), r


@pytest.mark.parametrize(("res", "control"), [
    (64, None), pytest.param(128, None, marks=pytest.mark.slow), (64, "rho_brightest")])
def test_cone_inside_the_bowl_does_not_read_its_brighter_outer_wall(ctx, res, control):
    """The outer wall at 2 L (0.1 thick: a level-1 texel at 32^3 holds both walls, hence from 64^3): the
    inner wall's cones read L within the same bounds (measured up to 1.026); the brightest face as the
    reference reads the outer wall through the coarse texels (1.66 L at 64^3)."""
    vs = lit_bowl(ctx, res, 2.0, control)
    r = blocked_cones(vs)
    vs.release()
    assert reads_the_wall(r) == (control is None), r


@pytest.mark.parametrize("control", [None, "corner_discounted"])
def test_two_fronts_of_different_radiance_keep_their_weights(ctx, control):
    """A half-space x < 0 of voxels whose +X faces show L and +Y faces L / 2 (both opaque), their -X and -Y
    faces black (nothing faces that way: no back of a lit surface on either axis). A cone along
    d = (-1, -0.6, 0) / |.| reads the faces against it, weighted d_a^2 (vct_read): (0.735 L + 0.265 L / 2) /
    (0.735 + 0.265) = 0.868 L times its opacity. Control: discounting the dimmer face by its radiance per
    opacity over the dominant one's there too reads L."""
    res, L = 32, 0.8
    vs = blank_voxels(ctx, res)
    if control == "corner_discounted":
        src = shader_source("vct_cone.comp", package=PACKAGE)
        old = "    if (b <= 0.0) return 1.0;\n"
        if old not in src:
            raise AssertionError(f"control {control}: {old!r} is no longer in vct_cone.comp")
        vs.cone_prog = ctx.compute_shader(src.replace(old, ""))
    f = np.zeros((6, 1, res, res, res, 4), "f4")
    half = slice(0, res // 2)
    f[0, 0, half], f[1, 0, half] = [L, L, L, 1.0], [0.0, 0.0, 0.0, 1.0]
    f[2, 0, half], f[3, 0, half] = [L / 2, L / 2, L / 2, 1.0], [0.0, 0.0, 0.0, 1.0]
    vs.write_level0(f)
    vs.build_mips()
    d = np.array([-1.0, -0.6, 0.0]) / math.sqrt(1.36)
    n = np.array([1.0, 0.0, 0.0])
    h = vs.grid.voxel_size
    r = vs.trace_cone(np.array([[0.3, 0.013, 0.013]]), d[None], np.array([0.1]), np.array([h]),
                      np.array([[0.3 - 2.0 * h, 0.013, 0.013]]), n[None])[0]
    vs.release()
    want = (1.0 + 0.36 * 0.5) / 1.36 * L
    assert r[3] > 0.99, r
    assert (r[:3].mean() / r[3] == pytest.approx(want, rel=0.01)) == (control is None), r


def test_the_shaders_lobe_share_above_the_horizon_is_the_numpy_one(ctx):
    """vct_trace.glsl's vct_lobe_above against vct_math.lobe_above_horizon (itself checked against sampling
    the lobe in tests/realtime/test_vct_math.py) on a grid of n . r and exponents."""
    src = ("#version 430\nlayout(local_size_x = 1) in;\nlayout(std430, binding = 0) buffer B { vec4 v[]; };\n"
           '#include "vct_trace.glsl"\n'
           "void main() { uint i = gl_GlobalInvocationID.x; v[i].x = vct_lobe_above(v[i].y, v[i].z); }\n")
    prog = ctx.compute_shader(expand_includes(src, PACKAGE))
    cases = [(s, n) for s in (-1.0, -0.4, -0.05, 0.0, 0.05, 0.19, 0.6, 1.0) for n in (0.0, 1.0, 50.0, 1000.0)]
    data = np.array([(0.0, s, n, 0.0) for s, n in cases], np.float32)
    buf = ctx.buffer(data.tobytes())
    buf.bind_to_storage_buffer(0)
    prog.run(len(cases))
    got = np.frombuffer(buf.read(), np.float32).reshape(-1, 4)[:, 0]
    expected = [vct_math.lobe_above_horizon(s, n) for s, n in cases]
    np.testing.assert_allclose(got, expected, atol=1e-4)  # float32 pow and acos: a few 1e-5
    buf.release()
    prog.release()
