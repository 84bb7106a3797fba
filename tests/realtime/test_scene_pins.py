"""Techniques as plugins change no scene's content: `Scene.to_dict()` (what a result row's content id
hashes, experiments/runs/sweep.py content_id) and `technique.describe()` (what a row and the render
metadata report) of every builtin scene, with 14 override sets covering every technique and its table,
equal what the code returned before the techniques were declared as data (tests/realtime/data/
scene_pins.json, written by that code). This pins the content ids: a failure here means resumed paper
runs would recompute their rows."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from realtime.engine import technique
from scenes.model import scene as scene_model

PINS = json.loads((Path(__file__).parent / "data" / "scene_pins.json").read_text())


def _json(value):
    return json.loads(json.dumps(value, default=list))


@pytest.mark.parametrize("pin", PINS, ids=[f"{p['scene']}-{i}" for i, p in enumerate(PINS)])
def test_to_dict_and_describe_unchanged(pin):
    base = scene_model.load(f"builtin:{pin['scene']}")
    if "error" in pin:
        with pytest.raises(scene_model.SceneError) as exc:
            base.with_overrides(pin["overrides"])
        assert str(exc.value) == pin["error"]
        return
    s = base.with_overrides(pin["overrides"])
    assert _json(s.content_dict()) == pin["to_dict"]
    described = _json(technique.describe(s))
    idle = described.pop("not_run", {})  # added since: the chosen techniques that do not run (technique.not_run)
    assert described == pin["describe"]
    assert all(k not in s.effects and described[k] != "none" for k in idle)


def test_pins_cover_every_builtin_choice_and_fail_on_a_change():
    """Every builtin technique is chosen in some pin, and the comparison sees a changed default
    (negative control: the same check on a scene with one table value changed fails)."""
    chosen = {(k, p["to_dict"]["realtime"][k]) for p in PINS if "to_dict" in p for k in technique.EFFECT_KEYS}
    # the pins predate the glTF material and its split sum, and wavelet PRT (scene_model.ADDED_KEYS), which
    # test_content_ids_of_scenes_using_added_keys covers
    added = {("glossy", "split_sum")} | {(e, "wavelet_prt") for e in ("diffuse", "occlusion", "interreflection")}
    assert set(technique.pairs()) - added <= chosen
    pin = next(p for p in PINS if "to_dict" in p and not p["overrides"])
    s = scene_model.load(f"builtin:{pin['scene']}").with_overrides({"realtime.prt.order": 3,
                                                                     "realtime.diffuse": "prt"})
    assert _json(s.content_dict()) != pin["to_dict"]


def test_content_ids_of_scenes_using_added_keys():
    """A scene that uses a key added since the pins (a pbr material, the split sum's table) hashes it, so a
    changed roughness or recipe is a different row; a scene that does not use them hashes none of them,
    though its to_dict has them (negative control)."""
    paper = scene_model.load("builtin:sphere-blend")
    assert "roughness" in paper.to_dict()["objects"][0]["material"] and "split_sum" in paper.to_dict()["realtime"]
    assert "roughness" not in paper.content_dict()["objects"][0]["material"]
    assert "split_sum" not in paper.content_dict()["realtime"]
    pbr = paper.with_overrides({"objects.0.material": {"type": "pbr", "roughness": 0.3},
                                "realtime.glossy": "split_sum"})
    content = pbr.content_dict()
    assert content["objects"][0]["material"]["roughness"] == 0.3
    assert content["realtime"]["split_sum"]["recipe"] == "khronos"
    assert pbr.with_overrides({"realtime.split_sum.recipe": "filament"}).content_dict() != content
    assert pbr.with_overrides({"objects.0.material.roughness": 0.4}).content_dict() != content
    assert "wavelet_prt" in paper.to_dict()["realtime"] and "wavelet_prt" not in paper.content_dict()["realtime"]
    wavelet = paper.with_overrides({"realtime.diffuse": "wavelet_prt"})
    assert wavelet.content_dict()["realtime"]["wavelet_prt"]["cube_size"] == 32
    assert wavelet.with_overrides({"realtime.wavelet_prt.terms": 64}).content_dict() != wavelet.content_dict()
