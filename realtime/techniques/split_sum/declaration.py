"""`realtime.glossy = "split_sum"`: Karis' split-sum IBL of the glTF metallic-roughness material with one
engine's recipe (recipes.py), declared as data (scenes/model/technique_registry.py); the OpenGL half is
split_sum.py."""

from __future__ import annotations

from dataclasses import dataclass, fields

from realtime.techniques.split_sum import recipes
from realtime.techniques.split_sum.dfg import PRECISIONS
from realtime.techniques.split_sum.ggx import VISIBILITIES
from realtime.techniques.split_sum.ibl_fresnel import MULTISCATTER
from realtime.techniques.split_sum.mappings import MAPPINGS
from realtime.techniques.split_sum.recipes import FROM_RECIPE
from scenes.model.technique_registry import (
    Check,
    Declaration,
    number,
    one_of,
    param,
    power_of_two,
    require_cube,
)
from scenes.storage.errors import SceneError


def _or_recipe(check: Check) -> Check:
    """`check`, or "recipe" (the recipe's value)."""
    fn, text = check

    def either(v):
        return v if v == FROM_RECIPE else fn(v)

    return either, f'{text} or "{FROM_RECIPE}" (the recipe\'s value)'


def _boolean() -> Check:
    return (lambda v: v if isinstance(v, bool) else None), "true or false"


@dataclass(frozen=True)
class SplitSum:
    """[realtime.split_sum]: the recipe, and each of its parameters ("recipe": the recipe's value)."""
    recipe: str = param("khronos", one_of(*recipes.NAMES))
    sampling: str = param(FROM_RECIPE, _or_recipe(one_of("importance", "vndf")))
    samples: int | str = param(FROM_RECIPE, _or_recipe(number(1, 65536, integer=True)))
    double_samples: bool | str = param(FROM_RECIPE, _or_recipe(_boolean()))
    fis_bias: float | str = param(FROM_RECIPE, _or_recipe(number(-16, 16)))
    lod_mapping: str = param(FROM_RECIPE, _or_recipe(one_of(*MAPPINGS)))
    size: int | str = param(FROM_RECIPE, _or_recipe(power_of_two(1, 4096)))
    min_size: int | str = param(FROM_RECIPE, _or_recipe(power_of_two(1, 4096)))
    lut_size: int | str = param(FROM_RECIPE, _or_recipe(power_of_two(2, 4096)))
    lut_samples: int | str = param(FROM_RECIPE, _or_recipe(number(1, 1 << 20, integer=True)))
    lut_precision: str = param(FROM_RECIPE, _or_recipe(one_of(*PRECISIONS)))
    visibility: str = param(FROM_RECIPE, _or_recipe(one_of(*VISIBILITIES)))
    multiscatter: str = param(FROM_RECIPE, _or_recipe(one_of(*MULTISCATTER)))


def validate(rt, given: dict, where: str) -> None:
    if rt.glossy != "split_sum":
        return
    require_cube(rt, "glossy", where)  # it convolves the cube map
    if rt.split_sum.recipe == "custom":
        missing = [f.name for f in fields(SplitSum) if getattr(rt.split_sum, f.name) == FROM_RECIPE]
        if missing:
            raise SceneError(f"{where}: realtime.split_sum.recipe = 'custom' with realtime.split_sum.{missing[0]} "
                             f"= {FROM_RECIPE!r}: a custom recipe has no values of its own; set "
                             + ", ".join(f"realtime.split_sum.{m}" for m in missing))


def describe(rt) -> dict:
    return {"split_sum": recipes.resolve(rt.split_sum)}


def row_label(t) -> str:
    """'split sum khronos', 'split sum custom 256 spl vndf'."""
    p = t.get("split_sum", {})
    label = f"split sum {p.get('recipe')}"
    return label if p.get("recipe") != "custom" else f"{label} {p.get('samples')} spl {p.get('sampling')}"


DECLARATIONS = (
    Declaration(
        effect="glossy", name="split_sum", rank=25, simulates=frozenset({"glossy"}),
        implementation="realtime.techniques.split_sum.split_sum:SplitSumGlossy",
        table="split_sum", parameters=SplitSum, table_hint='realtime.glossy = "split_sum"',
        timing_key="prefilter",
        reads=("realtime.split_sum.",),
        axes={"realtime.split_sum.recipe": ("khronos", "filament", "threejs", "babylon")},
        package=__package__, fragment_glsl=("glossy_split_sum.glsl",),
        validate=validate, describe=describe, row_label=row_label,
        materials=frozenset({"pbr"}),
    ),
)
