"""`realtime.glossy = "box"`: the paper's glossy lookup in the 2x2 box chain at a LOD per object, declared
as data (scenes/model/technique_registry.py); the OpenGL half is glossy_box.py."""

from __future__ import annotations

from dataclasses import dataclass

from scenes.model.technique_registry import Declaration, combination_error, number, one_of, param


@dataclass(frozen=True)
class BoxKeys:
    """The keys the box lookup reads flat in [realtime] (realtime/engine/levels.py)."""
    lod_bias: float = param(0.0, number(-32, 32))  # levels added to the paper's LOD
    lod_mapping: str = param("paper", one_of("paper", "mcguire"))  # the exponent -> LOD rule


def validate(rt, given: dict, where: str) -> None:
    """The paper's LOD knobs set explicitly (to other than their defaults) while another glossy technique runs."""
    for key, default in (("lod_bias", BoxKeys.lod_bias), ("lod_mapping", BoxKeys.lod_mapping)):
        if key in given and rt.glossy != "box" and getattr(rt, key) != default:
            raise combination_error(rt, key, "glossy", 'the paper\'s LOD rule applies to realtime.glossy = "box" '
                                    "only (the prefiltered chain has [realtime.prefiltered] bias)", where)


def describe(rt) -> dict:
    return {"lod_bias": rt.lod_bias, "lod_mapping": rt.lod_mapping}



def row_label(t) -> str:
    """'box bias 1', 'box bias 0 McGuire'."""
    return f"box bias {t.get('lod_bias'):g}" + (" McGuire" if t.get("lod_mapping") == "mcguire" else "")

DECLARATIONS = (
    Declaration(
        effect="glossy", name="box", rank=10, simulates=frozenset({"glossy"}),
        implementation="realtime.techniques.box.glossy_box:BoxGlossy",
        flat=BoxKeys,
        timing_key="filter",  # the chain is part of the paper's `filter`
        reads=("realtime.lod_bias", "realtime.lod_mapping"),
        axes={"realtime.lod_bias": (-1.0, 0.0, 1.0, 2.0), "realtime.lod_mapping": ("paper", "mcguire")},
        package=__package__, fragment_glsl=("glossy_box.glsl",),
        validate=validate, describe=describe, row_label=row_label,
    ),
)
