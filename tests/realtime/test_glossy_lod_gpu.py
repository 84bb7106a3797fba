"""The glossy lookup on the GPU reads the box chain at clamp(level(s) + offset(N) + b) (docs/contract.md section 3,
step 5).

Expectation, independent of realtime/: the base level is the Mitsuba-convention lookup of every texel
direction (scenes.environment.envmap / scenes.environment.cubemap, docs/contract.md section 2), the chain is 2x2
box-filtered here in
numpy, and each pixel's mirror direction (from the analytic sphere, not the mesh) is sampled trilinearly:
bilinear within a level at the texel the direction hits (texel centres at (i + 0.5) / size), linear
between the two levels around the LOD. Pixels whose bilinear footprint crosses a face edge (where the
GPU's seamless filtering blends two faces) are left out, and so are pixels within 2.5 px of the silhouette.

The environment is smooth (waves a few texels long), so the GPU's float32 fill, its fixed-point filter
weights and the tessellated sphere stay within 7e-4 relative (measured on llvmpipe), while half a level
of LOD moves the image by 2.5 % or more. Tolerance: 2e-3 relative, every selected pixel.
"""

from __future__ import annotations

import numpy as np
import pytest

import realtime
import scenes
from realtime.engine.context import get_context
from realtime.engine.gpu import EnvironmentFilter
from realtime.techniques.prefiltered.prefilter import PhongPrefilter
from scenes.environment import envmap
from scenes.environment.directions import equirect_directions
from tests.helpers import box_chain, trilinear

pytestmark = pytest.mark.gl

BASE = 64
SIZE = 48
TOL = 2e-3


def smooth_environment(h: int = 256, w: int = 512, k: float = 8.0) -> np.ndarray:
    """Waves of angular frequency ~k per channel: smooth over a texel, yet each level of box filtering
    changes them visibly (at k = 8 half a level moves the image by >= 2.5 % at every LOD used here)."""
    d = equirect_directions(h, w)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    r = 1.0 + 0.6 * np.sin(k * x + 1.0) * np.cos(0.8 * k * y) + 0.3 * z
    g = 1.0 + 0.5 * np.cos(1.2 * k * z - 0.5 * x) + 0.2 * y
    b = 1.0 + 0.4 * np.sin(0.8 * k * y + 0.6 * k * x) * np.sin(k * z)
    return np.stack([r, g, b], -1).astype(np.float32)


@pytest.fixture(scope="module")
def env_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("lod") / "smooth.exr"
    envmap.write(path, smooth_environment())
    return path


@pytest.fixture(scope="module")
def numpy_chain(env_file):
    """Levels 0 .. log2(BASE) of the cube map, each (6, s, s, 3) float64: lookups, then 2x2 box means."""
    return box_chain(envmap.read(env_file), BASE)


def mirror_directions(scene) -> tuple[np.ndarray, np.ndarray]:
    """(mirror direction per pixel (H, W, 3), interior mask) of the unit sphere at the origin."""
    cam = scene.camera
    o = np.asarray(cam.origin, dtype=np.float64)
    d = cam.pixel_rays()
    b = d @ o
    t = -b - np.sqrt(np.maximum(b * b - (o @ o - 1.0), 0.0))
    n = o + t[..., None] * d
    v = -d
    closest = np.sqrt(np.maximum(o @ o - b * b, 0.0))
    interior = closest < 1.0 - 2.5 * np.radians(cam.fov_deg) / cam.height * np.linalg.norm(o)
    return 2.0 * np.sum(n * v, axis=-1, keepdims=True) * n - v, interior


def glossy_scene(env_file, face_size: int, bias: float, mapping: str = "paper", exponent: float = 100.0):
    return scenes.load("builtin:sphere-phong").with_overrides({
        "environment.map": str(env_file), "camera.width": SIZE, "camera.height": SIZE,
        "realtime.timing_frames": 1, "realtime.warmup_frames": 0, "realtime.base_size": BASE,
        "realtime.face_size": face_size, "realtime.lod_bias": bias, "realtime.lod_mapping": mapping,
        "objects.0.resolution": 256, "objects.0.material.ks": [1.0, 1.0, 1.0],
        "objects.0.material.exponent": exponent})


def render_glossy(env_file, face_size, bias, mapping="paper", exponent=100.0):
    """(GPU image (H, W, 3), mirror directions (H, W, 3), interior & covered mask)."""
    scene = glossy_scene(env_file, face_size, bias, mapping, exponent)
    r = realtime.render(scene)
    refl, interior = mirror_directions(scene)
    return r.rgb, refl, interior & r.mask


def expected_at(chain, refl, lod) -> tuple[np.ndarray, np.ndarray]:
    value, inside = trilinear(chain, refl.reshape(-1, 3), lod)
    return value.reshape(refl.shape), inside.reshape(refl.shape[:2])


# (face size s, bias b, mapping, exponent N, the LOD worked out by hand; base 64, so level(s) = log2(64 / s))
CASES = [
    (64, 0.5, "paper", 100.0, 0.5),     # level 0 + 0.5
    (64, 1.5, "paper", 100.0, 1.5),     # level 0 + 1.5
    (32, -0.5, "paper", 100.0, 0.5),    # level 1 - 0.5
    (32, -3.0, "paper", 100.0, 0.0),    # level 1 - 3 = -2, clamped to the finest level
    (16, 1.25, "paper", 100.0, 3.25),   # level 2 + 1.25
    (16, 2.0, "paper", 100.0, 4.0),     # level 2 + 2
    # McGuire: offset = log2(s sqrt 3) - 0.5 log2(N + 1)
    (32, 0.0, "mcguire", 100.0, 3.463375508985),   # 1 + (5.792481250361 - 3.329105741376)
    (16, -0.7, "mcguire", 100.0, 2.763375508985),  # 2 + (4.792481250361 - 3.329105741376) - 0.7
    (64, 1.0, "mcguire", 1000.0, 2.808868120943),  # 0 + (6.792481250361 - 4.983613129418) + 1
]


@pytest.mark.parametrize(("face_size", "bias", "mapping", "exponent", "lod"), CASES,
                         ids=[f"s{c[0]}-b{c[1]:g}-{c[2]}-N{c[3]:g}" for c in CASES])
def test_glossy_image_is_the_box_chain_at_level_plus_offset_plus_bias(env_file, numpy_chain, face_size, bias,
                                                                       mapping, exponent, lod):
    rgb, refl, sel = render_glossy(env_file, face_size, bias, mapping, exponent)
    want, inside = expected_at(numpy_chain, refl, lod)
    sel &= inside
    assert sel.sum() > 300  # enough pixels away from face edges and the silhouette
    rel = np.abs(rgb[sel] - want[sel]) / want[sel]
    assert rel.max() < TOL, (rel.max(), np.median(rel))
    # the check can fail: half a level either way moves the expectation by far more than TOL
    for other in (lod - 0.5, lod + 0.5):
        if 0.0 <= other <= 4.0:
            shifted, inside_other = expected_at(numpy_chain, refl, other)
            both = sel & inside_other
            assert (np.abs(shifted[both] - want[both]) / want[both]).max() > 5 * TOL


def test_bias_two_levels_changes_the_image_clearly(env_file):
    """Bias 0 and bias 2 (face 32 of 64: levels 1 and 3) differ by far more than the tolerance above."""
    at0, _, sel = render_glossy(env_file, 32, 0.0)
    at2, _, _ = render_glossy(env_file, 32, 2.0)
    rel = np.abs(at2[sel] - at0[sel]) / at0[sel]
    assert np.median(rel) > 10 * TOL and rel.max() > 0.05, (np.median(rel), rel.max())


# (Phong exponent N, the LOD of its prefiltered chain worked out by hand: the level whose face is
# 2 x 2 texels per lobe sigma x sqrt(N) = 4 sqrt(N) texels, log2(64 / (4 sqrt N)); face size 64 = level 0
# does not clamp it)
PREFILTERED_CASES = [(20.0, 1.839035952556), (100.0, 0.678071905113)]
PREFILTERED_SAMPLES = 64
PREFILTERED_TOL = 1e-3


@pytest.mark.parametrize(("exponent", "lod"), PREFILTERED_CASES, ids=[f"N{c[0]:g}" for c in PREFILTERED_CASES])
def test_prefiltered_image_is_its_chain_read_trilinearly_at_the_lobe_lod(env_file, exponent, lod):
    """The `prefiltered` glossy lookup reads the object's Phong-prefiltered chain at its fractional
    LOD, linear between the two levels around it: every selected pixel equals the chain (made here by
    PhongPrefilter from the same box chain, its levels read back) sampled trilinearly in numpy at the
    analytic mirror direction and the LOD worked out by hand (PREFILTERED_CASES). The chain's contents are
    checked against exact lobe sums in test_prefilter.py; this checks the level the image reads.
    Measured: within 4e-4 relative on llvmpipe; reading only the level below the LOD moves pixels by 1 %
    (negative control below)."""
    scene = glossy_scene(env_file, BASE, 0.0, exponent=exponent).with_overrides({
        "realtime.glossy": "prefiltered", "realtime.prefiltered.samples": PREFILTERED_SAMPLES,
        "realtime.prefiltered.bias": 0.0})
    r = realtime.render(scene)
    refl, interior = mirror_directions(scene)
    env = EnvironmentFilter(get_context(), envmap.read(env_file), BASE)
    env.fill_base(0.0)
    env.build_chain()
    chain = PhongPrefilter(get_context(), BASE, exponent, PREFILTERED_SAMPLES, 0.0)
    lo = int(np.floor(lod))
    chain.run(env.cube, lo)
    # levels below lo are neither written nor read
    levels = [None] * lo + [chain.read_level(k).astype(np.float64) for k in range(lo, chain.n_levels)]
    chain.release()
    env.release()
    want, inside = expected_at(levels, refl, lod)
    sel = interior & r.mask & inside
    assert sel.sum() > 300
    rel = np.abs(r.rgb[sel] - want[sel]) / want[sel]
    assert rel.max() < PREFILTERED_TOL, (rel.max(), np.median(rel))
    # the check can fail: the level below the LOD alone (no blend towards the coarser one) is far off
    below, _ = expected_at(levels, refl, float(lo))
    assert (np.abs(below[sel] - want[sel]) / want[sel]).max() > 5 * PREFILTERED_TOL
