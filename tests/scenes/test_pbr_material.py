"""The glTF metallic-roughness material (`type = "pbr"`) in the scene model: its keys, their ranges and
reasons, the effects it calls for, the fields its cache key holds, and which techniques may shade it."""

from __future__ import annotations

import pytest

import scenes
from scenes.model import materials
from scenes.model.scene import SceneError

PBR = {"type": "pbr", "base_color": [0.9, 0.6, 0.3], "metallic": 1.0, "roughness": 0.3}


def pbr_scene(material: dict | None = None, **realtime):
    ov = {"objects.0.material": material or PBR, "realtime.glossy": "split_sum"}
    ov.update({f"realtime.{k}": v for k, v in realtime.items()})
    return scenes.load("builtin:sphere-blend").with_overrides(ov)


def test_a_pbr_material_loads_with_its_own_fields():
    m = pbr_scene().objects[0].material
    assert (m.type, m.base_color, m.metallic, m.roughness) == ("pbr", (0.9, 0.6, 0.3), 1.0, 0.3)


@pytest.mark.parametrize(("key", "value"), [("roughness", 1.5), ("roughness", -0.1), ("metallic", 2.0),
                                            ("metallic", -1e-9), ("roughness", float("nan")),
                                            ("base_color", [1.2, 0.5, 0.5])])
def test_factors_outside_zero_one_are_refused_naming_the_key_and_why(key, value):
    with pytest.raises(SceneError) as err:
        pbr_scene({**PBR, key: value})
    text = str(err.value)
    assert f"objects[0].material.{key}" in text and "[0, 1]" in text
    if key != "base_color":
        assert "glTF" in text  # the reason, not only the range


@pytest.mark.parametrize("value", [0.0, 1.0])
def test_the_ends_of_the_range_are_accepted(value):
    m = pbr_scene({**PBR, "roughness": value, "metallic": value}).objects[0].material
    assert m.roughness == value and m.metallic == value


@pytest.mark.parametrize(("material", "key"), [({**PBR, "kd": [0.5, 0.5, 0.5]}, "kd"),
                                               ({**PBR, "exponent": 10.0}, "exponent"),
                                               ({"type": "blend", "roughness": 0.5}, "roughness")])
def test_keys_of_another_type_are_refused(material, key):
    with pytest.raises(SceneError, match=f"material.{key}: unknown key"):
        scenes.load("builtin:sphere-blend").with_overrides({"objects.0.material": material})


@pytest.mark.parametrize(("metallic", "base_color", "diffuse"), [(0.0, [0.5, 0.5, 0.5], True),
                                                                 (0.5, [0.5, 0.5, 0.5], True),
                                                                 (1.0, [0.5, 0.5, 0.5], False),
                                                                 (0.0, [0.0, 0.0, 0.0], False)])
def test_effects_follow_the_lobes_the_material_has(metallic, base_color, diffuse):
    """A metal has no Lambert term, nor a black dielectric; every pbr material has a GGX lobe (F0 >= 0.04)
    and a Fresnel term."""
    sc = pbr_scene({**PBR, "metallic": metallic, "base_color": base_color})
    assert ("diffuse" in sc.effects) == diffuse
    assert {"glossy", "fresnel"} <= sc.effects


def test_the_cache_key_holds_the_pbr_fields_only():
    """An unused kd or exponent must not split the reference cache; a changed roughness must."""
    m = pbr_scene().objects[0].material
    assert materials.used_fields(m) == {"type": "pbr", "base_color": (0.9, 0.6, 0.3), "metallic": 1.0,
                                        "roughness": 0.3, "two_sided": False}
    other = pbr_scene({**PBR, "roughness": 0.31}).objects[0].material
    assert materials.used_fields(other) != materials.used_fields(m)


@pytest.mark.parametrize(("roughness", "alpha"), [(0.0, 0.045 ** 2), (0.01, 0.045 ** 2), (0.5, 0.25),
                                                  (1.0, 1.0)])
def test_alpha_is_roughness_squared_above_the_stated_minimum(roughness, alpha):
    assert materials.pbr_alpha(roughness) == pytest.approx(alpha, rel=1e-12)


@pytest.mark.parametrize("glossy", ["box", "prefiltered"])
def test_a_phong_chain_refuses_a_pbr_material(glossy):
    with pytest.raises(SceneError, match=r"objects\[0\].material.type = 'pbr' with realtime.glossy = "
                                         rf"\"{glossy}\".*split_sum"):
        pbr_scene(glossy=glossy)


def test_split_sum_refuses_a_paper_material():
    """Negative control of the rule above: the split sum's GGX chain cannot shade the paper's Phong lobe."""
    with pytest.raises(SceneError, match="material.type = 'blend' with realtime.glossy = \"split_sum\""):
        scenes.load("builtin:sphere-blend").with_overrides({"realtime.glossy": "split_sum"})


@pytest.mark.parametrize("diffuse", ["sh", "irradiance_map"])
def test_the_lambert_term_comes_from_a_diffuse_technique(diffuse):
    assert pbr_scene({**PBR, "metallic": 0.0}, diffuse=diffuse).realtime.diffuse == diffuse


def test_a_custom_recipe_names_every_parameter_it_lacks():
    with pytest.raises(SceneError, match="recipe = 'custom'.*set realtime.split_sum.sampling, "):
        pbr_scene(**{"split_sum.recipe": "custom", "split_sum.samples": 64})
