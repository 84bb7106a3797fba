"""benchmarks/env_chain_solid_angle.py against maps whose chains' means are known in closed form: a constant map
keeps its radiance at every level in both chains; a map of radiance 1 with a cap of 20 degrees about +y at 11
(inside the +y face) has sphere mean 1 + 5 (1 - cos 20 deg), and at the 1x1 level the box chain holds the +y face's
texel mean, 1 + 10 pi tan^2(20 deg) / 4 (the cap's gnomonic disc over the face's area), while the weighted chain
keeps the sphere's mean at every level."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from realtime.engine.context import get_context
from realtime.engine.gpu import EnvironmentFilter
from tests.helpers import CAP_HALF_ANGLE, cap_map

pytestmark = pytest.mark.gl

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("env_chain_solid_angle",
                                               ROOT / "benchmarks" / "env_chain_solid_angle.py")
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)

CAP = float(CAP_HALF_ANGLE)


def means(env: np.ndarray) -> list[tuple[int, float, float]]:
    f = EnvironmentFilter(get_context(), env.astype(np.float32), 64)
    try:
        f.fill_base(0.0)
        f.build_chain()
        return bench.chain_means(f)
    finally:
        f.release()


def test_a_constant_map_keeps_its_mean_in_both_chains():
    rows = means(np.full((128, 256, 3), 2.5))
    assert [level for level, *_ in rows] == list(range(7))
    for _, box, weighted in rows:
        assert box == pytest.approx(1.0, abs=1e-6)
        assert weighted == pytest.approx(1.0, abs=1e-6)


def test_a_cap_at_a_faces_centre_is_missed_by_the_box_chain_only():
    rows = means(cap_map())
    sphere = 1.0 + 5.0 * (1.0 - math.cos(CAP))
    box_top = (5.0 + 1.0 + 10.0 * math.pi * math.tan(CAP) ** 2 / 4.0) / 6.0 / sphere  # 0.902
    assert rows[-1][1] == pytest.approx(box_top, rel=0.01)
    assert rows[1][1] == pytest.approx(1.0, abs=0.002)  # 32^2: a texel's children are nearly alike
    for _, _, weighted in rows:
        assert weighted == pytest.approx(1.0, abs=1e-5)
