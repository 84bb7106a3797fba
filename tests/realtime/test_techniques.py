"""The technique interface (docs/contract.md section 9): scene keys, refusals, composition."""

from __future__ import annotations

import pytest

import scenes
from realtime.engine import technique
from realtime.engine.environment_maps import STORES
from scenes import SceneError
from scenes.model.scene import NOT_IMPLEMENTED, SCHEMA

CHOICE_KEYS = ("diffuse", "glossy", "occlusion", "interreflection", "parameterization")


def choices(key: str) -> list[str]:
    text = SCHEMA["realtime"][key][1]
    return [c.strip().strip('"') for c in text.removeprefix("one of ").split(",")]


@pytest.mark.parametrize("key", CHOICE_KEYS)
def test_every_choice_is_a_technique_or_refused_as_not_implemented(key):
    for value in choices(key):
        implemented = ((key, value) in technique.pairs() or value == "none"
                       or (key == "parameterization" and value in STORES))
        assert implemented != ((key, value) in NOT_IMPLEMENTED), (key, value)
        if implemented and (key, value) in technique.pairs():
            decl = technique.declaration_of(key, value)
            assert decl.effect == key and decl.name == value and key in decl.simulates
            cls = decl.load()  # its OpenGL class exists and is a Technique
            assert issubclass(cls, technique.Technique)


def test_a_value_marked_not_implemented_is_refused_not_ignored(monkeypatch):
    # every value is built today (NOT_IMPLEMENTED is empty); the refusal stays for the next technique a
    # scene key names before realtime/ has it: mark a built one and check that it is refused, not ignored
    import scenes.model.scene as scene_module

    monkeypatch.setattr(scene_module, "NOT_IMPLEMENTED", frozenset({("diffuse", "irradiance_map")}))
    with pytest.raises(SceneError) as err:
        scenes.load("builtin:sphere-blend").with_overrides({"realtime.diffuse": "irradiance_map"})
    assert "realtime.diffuse = 'irradiance_map': not implemented yet" in str(err.value)


@pytest.mark.parametrize(("overrides", "names"), [
    ({"realtime.prefiltered.samples": 64}, ["realtime.prefiltered", 'realtime.glossy = "prefiltered"']),
    ({"realtime.irradiance_map.size": 16}, ["realtime.irradiance_map", 'realtime.diffuse = "irradiance_map"']),
    ({"realtime.glossy": "prefiltered", "realtime.prefiltered.count": 3}, ["realtime.prefiltered.count",
                                                                          "unknown key"]),
    ({"realtime.occlusion": "shadow_maps"}, ["realtime.occlusion", "realtime.diffuse"]),
    ({"realtime.diffuse": "irradiance_map", "realtime.sh_order": 4}, ["realtime.sh_order", "realtime.diffuse"]),
    ({"realtime.diffuse": "irradiance_map", "realtime.sh_window": "auto"}, ["realtime.sh_window",
                                                                             "realtime.diffuse"]),
    ({"realtime.glossy": "prefiltered", "realtime.lod_bias": 1.0}, ["realtime.lod_bias", "realtime.glossy"]),
    ({"realtime.glossy": "prefiltered", "realtime.lod_mapping": "mcguire"}, ["realtime.lod_mapping",
                                                                               "realtime.glossy"]),
    ({"realtime.parameterization": "dual_paraboloid", "realtime.glossy": "prefiltered"},
     ["realtime.glossy", "realtime.parameterization"]),
    ({"realtime.parameterization": "sphere_map", "realtime.diffuse": "irradiance_map"},
     ["realtime.diffuse", "realtime.parameterization"]),
    ({"realtime.sphere_map.capture": [1.0, 0.0, 0.0]}, ["realtime.sphere_map",
                                                        'realtime.parameterization = "sphere_map"']),
    ({"realtime.parameterization": "sphere_map", "realtime.sphere_map.capture": [0.0, 0.0, 0.0]},
     ["realtime.sphere_map.capture", "not all zero"]),
    ({"realtime.reflection": "per_face"}, ["realtime.reflection", '"per_vertex"']),
    ({"realtime.diffuse": "irradiance_map", "realtime.base_size": 64, "realtime.face_size": 16,
      "realtime.irradiance_map.source_size": 128},
     ["realtime.irradiance_map.source_size", "realtime.base_size"]),
    # the light array and precomputed transfer
    ({"realtime.diffuse": "lights", "realtime.lights.count": 40}, ["realtime.lights.count", "42, 66"]),
    ({"realtime.diffuse": "lights", "realtime.lights.placement": "median_cut", "realtime.lights.count": 42},
     ["realtime.lights.count", "realtime.lights.placement", "power of two"]),
    ({"realtime.diffuse": "lights", "realtime.lights.shadow_map_size": 256},
     ["realtime.lights.shadow_map_size", "realtime.occlusion"]),
    ({"realtime.diffuse": "lights", "realtime.occlusion": "shadow_maps", "realtime.lights.count": 642,
      "realtime.lights.shadow_map_size": 1024}, ["realtime.lights.count", "realtime.lights.shadow_map_size", "GiB"]),
    ({"realtime.occlusion": "prt"}, ["realtime.occlusion", "realtime.diffuse"]),
    ({"realtime.diffuse": "prt", "realtime.occlusion": "prt", "realtime.interreflection": "prt"},
     ["realtime.interreflection", "realtime.prt.bounces"]),
    ({"realtime.diffuse": "prt", "realtime.prt.bounces": 1}, ["realtime.prt.bounces", "realtime.interreflection"]),
    ({"realtime.diffuse": "prt", "realtime.prt.rays": 64}, ["realtime.prt.rays", "realtime.occlusion"]),
    ({"realtime.diffuse": "prt", "realtime.prt.order": 9}, ["realtime.prt.order"]),
    ({"reference.lighting": "light_array"}, ["reference.lighting", "realtime.diffuse"]),
    ({"realtime.diffuse": "prt", "objects.0.material.two_sided": True}, ["realtime.diffuse", "objects[0]",
                                                                          "two_sided", "front side"]),
])
def test_unused_tables_and_nonsense_combinations_name_both_keys(overrides, names):
    with pytest.raises(SceneError) as err:
        scenes.load("builtin:sphere-blend").with_overrides(overrides)
    for name in names:
        assert name in str(err.value)


def test_parameterization_keys_are_read_and_described():
    s = scenes.load("builtin:sphere-blend").with_overrides({"realtime.parameterization": "sphere_map",
                                                             "realtime.sphere_map.capture": [0, 0, -1],
                                                             "realtime.reflection": "per_vertex"})
    assert s.realtime.sphere_map.capture == (0.0, 0.0, -1.0)
    d = technique.describe(s)
    assert d["parameterization"] == "sphere_map" and d["sphere_map"] == {"capture": [0.0, 0.0, -1.0]}
    assert d["reflection"] == "per_vertex"
    assert scenes.load("builtin:sphere-blend").realtime.sphere_map.capture == "camera"


def test_a_small_base_size_needs_no_irradiance_map_source():
    # the irradiance map's default source_size (32) applies only where the irradiance map runs
    s = scenes.load("builtin:sphere-blend").with_overrides({"realtime.base_size": 16, "realtime.face_size": 16})
    assert s.realtime.base_size == 16
    with pytest.raises(SceneError, match="realtime.irradiance_map.source_size"):
        s.with_overrides({"realtime.diffuse": "irradiance_map"})


def test_a_used_table_is_read():
    s = scenes.load("builtin:sphere-blend").with_overrides({"realtime.glossy": "prefiltered",
                                                             "realtime.prefiltered.samples": 64})
    assert s.realtime.prefiltered.samples == 64
    assert technique.describe(s)["prefiltered"]["samples"] == 64


@pytest.mark.parametrize(("spec", "missing"), [
    ("builtin:sphere-diffuse", []), ("builtin:sphere-phong", []), ("builtin:sphere-blend", []),
    ("builtin:teapot-blend", ["interreflection", "occlusion"]), ("builtin:bowl-diffuse", ["interreflection",
                                                                                          "occlusion"]),
    ("builtin:torus-phong", ["interreflection", "occlusion"]),
    ("builtin:sphere-on-plane", ["interreflection", "occlusion"])])
def test_unsimulated_effects(spec, missing):
    assert technique.unsimulated_effects(scenes.load(spec)) == missing


@pytest.mark.parametrize(("spec", "overrides", "missing"), [
    # PRT transfers diffuse light only: a blend's highlights stay unshadowed
    ("builtin:teapot-blend", {"realtime.diffuse": "prt", "realtime.occlusion": "prt"},
     ["interreflection", "glossy occlusion"]),
    ("builtin:teapot-blend", {"realtime.diffuse": "prt", "realtime.occlusion": "prt", "realtime.interreflection":
                              "prt", "realtime.prt.bounces": 1}, ["glossy occlusion", "glossy interreflection"]),
    ("builtin:bowl-diffuse", {"realtime.diffuse": "prt", "realtime.occlusion": "prt", "realtime.interreflection":
                              "prt", "realtime.prt.bounces": 2}, []),
    # shadow maps shadow what the light array lights: both lobes, or only the diffuse one
    ("builtin:teapot-blend", {"realtime.diffuse": "lights", "realtime.glossy": "lights",
                              "realtime.occlusion": "shadow_maps"}, ["interreflection"]),
    ("builtin:teapot-blend", {"realtime.diffuse": "lights", "realtime.occlusion": "shadow_maps"},
     ["interreflection", "glossy occlusion"]),
])
def test_a_technique_that_reaches_one_lobe_names_the_other(spec, overrides, missing):
    assert technique.unsimulated_effects(scenes.load(spec).with_overrides(overrides)) == missing


def test_only_the_scenes_effects_get_techniques():
    # a diffuse technique chosen for a scene without diffuse is not run (docs/contract.md section 4)
    s = scenes.load("builtin:sphere-phong").with_overrides({"realtime.diffuse": "irradiance_map"})
    assert technique.needed(s) == [("glossy", "box")]
    s = scenes.load("builtin:sphere-blend").with_overrides({"realtime.glossy": "prefiltered"})
    assert technique.needed(s) == [("diffuse", "sh"), ("glossy", "prefiltered")]


def test_owner_of_technique_keys():
    assert technique.owner_of("realtime.lod_bias") == ("glossy", "box")
    assert technique.owner_of("realtime.sh_order") == ("diffuse", "sh")
    assert technique.owner_of("realtime.prefiltered.samples") == ("glossy", "prefiltered")
    assert technique.owner_of("realtime.irradiance_map.size") == ("diffuse", "irradiance_map")
    assert technique.owner_of("realtime.face_size") is None


@pytest.mark.parametrize(("face", "exponent", "want"), [
    # w = 4 sqrt(N) texels per face (at least 8); lod = log2(256 / w), never finer than level(s)
    (64, 100.0, 2.678071905),  # w = 40: 8 - 2 - log2(10) = log2(6.4)
    (64, 10.0, 4.339035953),  # w = 12.649: 8 - 2 - log2(10) / 2
    (64, 0.0, 5.0),  # a hemisphere: the 8-texel floor, log2(32)
    (64, 1e4, 2.0),  # w = 400 > 256: the selected level 2 (face 64) bounds it
    (256, 1e4, 0.0),  # ... and at face 256 the base level
    (16, 100.0, 4.0),  # level(16) = 4 is coarser than the lobe's 2.678
])
def test_prefiltered_lod_by_hand(face, exponent, want):
    from realtime.engine import levels

    assert levels.prefiltered_lod(face, 256, exponent) == pytest.approx(want, abs=1e-8)
