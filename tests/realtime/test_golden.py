"""The paper's images do not change: every builtin scene and a few paper-knob variants,
rendered in real time at 48x48, are bit-identical to the images the paper's method produced before
the techniques refactor (tests/data/realtime_golden.npz, made by tests/data/make_realtime_golden.py).

One deliberate exception: McGuire's LOD offset log2(s sqrt 3) - log2(N + 1) / 2 used to be evaluated
in float32 inside shade.frag and is now computed once in float64 on the host (realtime.engine.levels, as the
issue asks); the two differ in the last bit of the LOD, which moves trilinear weights by ~1e-7, so
that case must agree to 1e-6 relative, not bit for bit (measured: 2.4e-7).

Regenerated once since, for the back-face rule (black where the shading normal faces away from the
viewer): 3 of teapot-blend's 434 covered pixels, back faces seen through the open teapot that were dark
(at most 0.02) before, are now 0; nothing else changed (the McGuire case is now stored as it renders).

Bit-identity holds on the rasteriser that made the data (Mesa llvmpipe); a hardware GPU rounds
differently (other texture filtering and transcendental precision), so there the images must agree
to 2e-3 relative instead.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.gl

DATA = Path(__file__).resolve().parents[1] / "data"
_spec = importlib.util.spec_from_file_location("make_realtime_golden", DATA / "make_realtime_golden.py")
golden = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(golden)


#: cases whose LOD is now computed in float64 on the host instead of float32 in the shader
LOD_NOW_FLOAT64 = {"sphere-blend-mcguire"}


@pytest.fixture(scope="module")
def saved():
    return np.load(DATA / "realtime_golden.npz")


@pytest.mark.parametrize("name,spec,overrides", golden.CASES, ids=[c[0] for c in golden.CASES])
def test_paper_image_unchanged(saved, name, spec, overrides):
    import realtime
    import scenes
    from realtime.engine.context import is_software

    r = realtime.render(scenes.load(spec).with_overrides(golden.small(overrides)))
    want_rgb, want_mask = saved[f"{name}/rgb"], saved[f"{name}/mask"]
    np.testing.assert_array_equal(r.mask, want_mask)
    if is_software() and name not in LOD_NOW_FLOAT64:
        np.testing.assert_array_equal(r.rgb, want_rgb)
    elif is_software():
        np.testing.assert_allclose(r.rgb, want_rgb, rtol=1e-6, atol=0)
    else:
        scale = float(np.abs(want_rgb).max()) or 1.0
        np.testing.assert_allclose(r.rgb, want_rgb, rtol=2e-3, atol=2e-3 * scale)
