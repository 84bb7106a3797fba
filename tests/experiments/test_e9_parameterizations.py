"""E9's pieces that need neither OpenGL nor Mitsuba (experiments/paper/e09_parameterizations.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import scenes
from experiments.paper import e09_parameterizations as e9


def test_sampling_rates_at_a_budget():
    rates = {x["param"]: x for x in e9.sampling_rates(64)}
    assert rates["cube"]["texels"] == 6 * 64 * 64
    assert rates["dual_paraboloid"]["texels"] == 2 * 128 * 128 and rates["sphere_map"]["texels"] == 128 * 128
    assert rates["cube"]["limit"] == pytest.approx(3 * math.sqrt(3))
    # below their limits at a finite budget, above 1
    assert 1.0 < rates["cube"]["ratio"] < 3 * math.sqrt(3)
    assert 1.0 < rates["dual_paraboloid"]["ratio"] < 4.0
    assert rates["sphere_map"]["ratio"] == pytest.approx(1.0)
    # the gnomonic cube stretches sqrt(3):1 at its corners (in the limit), the paraboloid is conformal, and
    # the sphere map's stretch at its outermost full texel is 1 / (1 - rho^2)
    assert rates["cube"]["stretch"] < math.sqrt(3)
    assert rates["cube"]["stretch"] > math.sqrt(3) * 0.97
    assert rates["dual_paraboloid"]["stretch"] == pytest.approx(1.0, abs=1e-4)
    assert rates["sphere_map"]["stretch"] > 20


@pytest.mark.parametrize(("angle", "want"), [(0.0, (0.0, 0.0, -1.0)), (90.0, (-1.0, 0.0, 0.0)),
                                             (180.0, (0.0, 0.0, 1.0))])
def test_capture_directions_turn_the_view_about_y(angle, want):
    np.testing.assert_allclose(e9.capture_direction(angle), want, atol=1e-12)


def test_every_e9_configuration_is_a_valid_scene():
    s = e9.QUICK
    for label, spec, ov in e9.SCENES:
        for face in s.budgets:
            for p in e9.PARAMS:
                scenes.load(spec).with_overrides({**ov, **e9.budget_ov(p, face, label != e9.DIFFUSE[0])})
    for a in s.angles:
        sc = scenes.load(e9.MIRROR[1]).with_overrides({**e9.MIRROR[2], **e9.budget_ov("sphere_map", 64, True),
                                                        "realtime.sphere_map.capture": e9.capture_direction(a)})
        assert sc.realtime.sphere_map.capture == tuple(e9.capture_direction(a))
    for _, spec, ov in e9.vertex_scenes(s):
        sc = scenes.load(spec).with_overrides({**ov, **e9.budget_ov("cube", 64, True),
                                               "realtime.reflection": "per_vertex"})
        assert "glossy" in sc.effects
    rows = (len(e9.SCENES) * len(s.budgets) * len(e9.PARAMS) + 2 * len(s.angles)
            + len(e9.vertex_scenes(s)) * len(s.vertex_params) * 2)
    assert e9.count_steps(e9.QUICK) == rows + 1
