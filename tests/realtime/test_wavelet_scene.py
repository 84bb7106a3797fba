"""`realtime.diffuse = "wavelet_prt"` as a scene chooses it: registration, parameter checks and combination
rules (realtime/techniques/wavelet_prt/declaration.py), each refusal with a valid neighbour as its control.
The technique is found through its installed entry point, as every technique is."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import scenes
from realtime.engine import technique
from scenes.model import technique_registry as reg
from scenes.storage.errors import SceneError

ENTRY = "realtime.techniques.wavelet_prt.declaration:DECLARATIONS"


def wavelet_scene(name: str = "builtin:sphere-on-plane", **overrides) -> scenes.Scene:
    return scenes.load(name).with_overrides({"realtime.diffuse": "wavelet_prt", **overrides})


def test_the_entry_point_in_pyproject_names_the_declarations():

    data = tomllib.loads((Path(__file__).resolve().parents[2] / "pyproject.toml").read_text())
    assert data["project"]["entry-points"]["iblcheck.techniques"]["wavelet_prt"] == ENTRY


def test_registered_for_the_three_effects_with_defaults():
    assert [reg.lookup(e, "wavelet_prt").effect for e in ("diffuse", "occlusion", "interreflection")] == \
        ["diffuse", "occlusion", "interreflection"]
    scene = wavelet_scene()
    w = scene.realtime.wavelet_prt
    assert (w.cube_size, w.terms, w.threshold, w.bounces) == (32, 256, 1e-4, 0)
    assert technique.describe(scene)["wavelet_prt"] == {"cube_size": 32, "terms": 256, "threshold": 1e-4}


@pytest.mark.parametrize(("overrides", "message"), [
    ({"realtime.wavelet_prt.terms": 6 * 16 * 16 + 1, "realtime.wavelet_prt.cube_size": 16}, "at most 1536"),
    ({"realtime.wavelet_prt.cube_size": 256, "realtime.base_size": 512}, "power of two in [8, 128]"),
    ({"realtime.wavelet_prt.cube_size": 48}, "power of two"),
    ({"realtime.wavelet_prt.cube_size": 64, "realtime.base_size": 32, "realtime.face_size": 32},
     "at most realtime.base_size"),
    ({"realtime.wavelet_prt.threshold": -1e-3}, "realtime.wavelet_prt.threshold"),
    ({"realtime.wavelet_prt.terms": 0}, "realtime.wavelet_prt.terms"),
    ({"realtime.occlusion": "wavelet_prt", "realtime.diffuse": "sh"}, 'realtime.diffuse = "wavelet_prt"'),
    ({"realtime.interreflection": "wavelet_prt", "realtime.wavelet_prt.bounces": 1}, "includes its shadowing"),
    ({"realtime.occlusion": "wavelet_prt", "realtime.interreflection": "wavelet_prt"}, "at least one bounce"),
    ({"realtime.wavelet_prt.bounces": 2}, "bounces are gathered"),
    ({"realtime.wavelet_prt.rays": 64}, "hemisphere rays"),
    ({"objects.0.material.two_sided": True}, "two_sided"),
])
def test_refusals_name_the_keys(overrides, message):
    with pytest.raises(SceneError, match=message.replace("[", r"\[").replace("]", r"\]").replace("^", r"\^")):
        wavelet_scene(**overrides)


@pytest.mark.parametrize("overrides", [
    {"realtime.wavelet_prt.terms": 6 * 16 * 16, "realtime.wavelet_prt.cube_size": 16},  # exactly all terms
    {"realtime.wavelet_prt.cube_size": 32, "realtime.base_size": 32, "realtime.face_size": 32},
    {"realtime.wavelet_prt.threshold": 0.0},
    {"realtime.occlusion": "wavelet_prt", "realtime.interreflection": "wavelet_prt", "realtime.wavelet_prt.bounces": 1,
     "realtime.wavelet_prt.rays": 64},
])
def test_valid_neighbours_load(overrides):
    """Controls of the refusals: the nearest valid settings load, and describe what runs."""

    d = technique.describe(wavelet_scene(**overrides))["wavelet_prt"]
    for key, value in overrides.items():
        if key.startswith("realtime.wavelet_prt."):
            assert d[key.rsplit(".", 1)[1]] == value


def test_only_the_diffuse_lobe_is_transferred():
    """A blend material's glossy lobe is not shadowed by the wavelet transfer: reported as unsimulated, as PRT's
    (control: the same scene with PRT says the same, a diffuse-only scene says nothing of the kind)."""

    overrides = {"realtime.occlusion": "wavelet_prt", "objects.0.material.type": "blend",
                 "objects.0.material.ks": [0.3, 0.3, 0.3], "objects.0.material.exponent": 50.0}
    scene = wavelet_scene(**overrides)
    assert "glossy occlusion" in technique.unsimulated_effects(scene)
    prt = scene.with_overrides({"realtime.diffuse": "prt", "realtime.occlusion": "prt"})
    assert "glossy occlusion" in technique.unsimulated_effects(prt)
    assert not any("glossy" in e for e in technique.unsimulated_effects(wavelet_scene(
        **{"realtime.occlusion": "wavelet_prt"})))


def test_describe_reports_the_gather_only_with_bounces():

    scene = wavelet_scene(**{"realtime.occlusion": "wavelet_prt", "realtime.interreflection": "wavelet_prt",
                             "realtime.wavelet_prt.bounces": 2, "realtime.wavelet_prt.rays": 64})
    assert technique.describe(scene)["wavelet_prt"] == {"cube_size": 32, "terms": 256, "threshold": 1e-4,
                                                        "rays": 64, "bounces": 2}
    s = technique.declaration_of("diffuse", "wavelet_prt").effective_settings(scene)
    assert (s.rays, s.bounces, s.shadowed) == (64, 2, True)
    s0 = technique.declaration_of("diffuse", "wavelet_prt").effective_settings(wavelet_scene())
    assert (s0.rays, s0.bounces, s0.shadowed) == (0, 0, False)  # no gather: no rays in the cache key
