"""benchmarks/vct_sphere_cones.py's exact share, the measure each cone's read is held against, checked in closed
form: a cap about the direction to a sphere's centre, wider than the sphere's angular radius s, has the sphere cover
(1 - cos s) / (1 - cos a) of it (the sphere's disc of directions inside the cap); one narrower than s is covered
whole; one turned away meets nothing, nor does a cap beside the sphere. No GL: the cones' reads are what the
benchmark prints."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("vct_sphere_cones", ROOT / "benchmarks" / "vct_sphere_cones.py")
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)

CENTRE = np.array([0.0, 1.5, 0.0])
ORIGIN = np.zeros(3)
S = math.asin(0.5 / 1.5)  # the sphere's angular radius seen from the origin, 19.47 deg


@pytest.mark.parametrize("half_deg", [25.0, 33.6, 60.0])
def test_a_cap_about_the_sphere_is_covered_by_its_disc_of_directions(half_deg):
    a = math.radians(half_deg)
    share = bench.blocked_share(np.array([0.0, 1.0, 0.0]), a, CENTRE, 0.5, ORIGIN)
    exact = (1.0 - math.cos(S)) / (1.0 - math.cos(a))
    assert share == pytest.approx(exact, abs=4.0 * math.sqrt(exact * (1.0 - exact) / 200_000) + 1e-4)


def test_a_cap_inside_the_sphere_is_covered_whole_and_one_turned_away_not_at_all():
    up = np.array([0.0, 1.0, 0.0])
    assert bench.blocked_share(up, math.radians(15.0), CENTRE, 0.5, ORIGIN) == 1.0
    assert bench.blocked_share(-up, math.radians(60.0), CENTRE, 0.5, ORIGIN) == 0.0
    # beside it: a 10-degree cap whose axis is 40 degrees off the centre's direction (more than s + 10)
    side = np.array([math.sin(math.radians(40.0)), math.cos(math.radians(40.0)), 0.0])
    assert bench.blocked_share(side, math.radians(10.0), CENTRE, 0.5, ORIGIN) == 0.0
