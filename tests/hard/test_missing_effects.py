"""The warning about missing effects describes what the two compared images miss.

The real-time side alone says "the scene calls for interreflection, which the chosen techniques do not
simulate"; but a reference rendered with the direct integrator (a light array's, or any) has no
interreflection either: both images lack it, and the comparison does not measure it. measure_pair
compares the two images' lists (experiments/measure/pair.py `effects_compared`); the commands that
compare hold back the real-time warning (comparison.render_realtime).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import scenes
from experiments.measure import comparison, pair
from scenes.model.render import Render

BOWL = scenes.load("builtin:bowl-diffuse")  # effects: diffuse, occlusion, interreflection
SPHERE = scenes.load("builtin:sphere-blend")  # no occlusion, no interreflection


def rt(*missing: str) -> Render:
    return Render(np.zeros((4, 4, 3), np.float32), np.ones((4, 4), bool), {}, {"unsimulated_effects": list(missing)})


def mitsuba(integrator: str) -> Render:
    return Render(np.zeros((4, 4, 3), np.float32), np.ones((4, 4), bool), {},
                  {"renderer": "reference", "integrator": integrator})


QUADRATURE = Render(np.zeros((4, 4, 3), np.float32), np.ones((4, 4), bool), {},
                    {"renderer": "quadrature", "occlusion": False})

CASES = [  # (test, reference, scene, [(start of each sentence, effects named)])
    (rt("interreflection"), mitsuba("direct"), BOWL, [("neither image simulates", "interreflection")]),
    (rt("interreflection"), mitsuba("path"), BOWL, [("the real-time image lacks", "interreflection")]),
    (rt("occlusion", "interreflection"), mitsuba("direct"), BOWL,
     [("the real-time image lacks", "occlusion"), ("neither image simulates", "interreflection")]),
    (rt(), mitsuba("direct"), BOWL, [("the reference (direct integrator) lacks", "interreflection")]),
    (rt("glossy occlusion", "interreflection"), QUADRATURE, BOWL,
     [("neither image simulates", "glossy occlusion, interreflection")]),
    (rt(), QUADRATURE, BOWL, [("the quadrature (unoccluded) lacks", "interreflection, occlusion")]),
    (rt("interreflection"), Render(np.zeros((4, 4, 3), np.float32), np.ones((4, 4), bool), {}, {}), BOWL,
     [("the real-time image lacks", "interreflection")]),  # an unknown reference: taken as complete
]


@pytest.mark.parametrize(("test", "ref", "scene", "want"), CASES, ids=[f"case{i}" for i in range(len(CASES))])
def test_the_sentences_name_what_each_image_misses(test, ref, scene, want):
    lines = pair.effects_compared(test, ref, scene)
    assert len(lines) == len(want), lines
    for line, (start, effects) in zip(lines, want, strict=True):
        assert line.startswith(start) and effects in line, line


def test_nothing_missing_says_nothing():
    """Negative controls: a scene without interreflection against a direct reference; complete images."""
    assert pair.effects_compared(rt(), mitsuba("direct"), SPHERE) == []
    assert pair.effects_compared(rt(), mitsuba("path"), BOWL) == []


def test_measure_pair_warns_once_per_sentence():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pair.measure_pair(rt("interreflection"), mitsuba("direct"), BOWL)
    lines = [str(w.message) for w in caught if issubclass(w.category, pair.MissingEffects)]
    assert lines == [f"{BOWL.name}: neither image simulates interreflection (the reference (direct integrator) "
                     "leaves it out too); the comparison does not measure it"]


@pytest.mark.gl
def test_render_realtime_holds_back_the_one_sided_warning():
    from realtime.engine.frame import UnsimulatedEffectWarning

    scene = BOWL.with_overrides({"camera.width": 16, "camera.height": 16, "realtime.timing_frames": 1,
                                 "realtime.warmup_frames": 0})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = comparison.render_realtime(scene)
    assert not [w for w in caught if issubclass(w.category, UnsimulatedEffectWarning)]
    assert "interreflection" in out.meta["unsimulated_effects"]  # still recorded in the render's meta
    # negative control: a plain realtime.render still warns (`iblcheck render` has no reference to compare)
    import realtime

    with pytest.warns(UnsimulatedEffectWarning, match="calls for"):
        realtime.render(scene)


@pytest.mark.gl
@pytest.mark.mitsuba
def test_light_array_reference_with_the_direct_integrator(tmp_path, monkeypatch):
    """The issue's case: `reference.lighting = "light_array"`, direct integrator: one line, saying both lack it."""
    from experiments.runs import gate

    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))
    scene = BOWL.with_overrides({"camera.width": 24, "camera.height": 24, "realtime.timing_frames": 1,
                                 "realtime.warmup_frames": 0, "reference.spp": 8, "reference.integrator": "direct",
                                 "reference.lighting": "light_array", "realtime.diffuse": "lights"})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gate.measure(scene, noise=False)
    lines = [str(w.message) for w in caught]
    assert not any("calls for" in line for line in lines), lines
    assert any("neither image simulates interreflection" in line for line in lines), lines
