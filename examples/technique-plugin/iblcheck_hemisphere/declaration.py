"""What `realtime.diffuse = "hemisphere"` is, as data iblcheck's registry reads without OpenGL
(scenes/model/technique_registry.py in iblcheck): its choice, its table, its timing key, what a
sweep and the accuracy/time ladder vary, its GLSL."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from scenes.model.technique_registry import Declaration, number, param


@dataclass(frozen=True)
class Hemisphere:
    """[realtime.hemisphere]"""
    ground_scale: float = param(1.0, number(0, 10))  # the ground's radiance times this (0: a black ground)


def describe(rt) -> dict:
    return {"hemisphere": asdict(rt.hemisphere)}


DECLARATION = Declaration(
    effect="diffuse", name="hemisphere", simulates=frozenset({"diffuse"}),
    implementation="iblcheck_hemisphere.hemisphere:HemisphereDiffuse",
    table="hemisphere", parameters=Hemisphere,
    timing_key="hemisphere",
    reads=("realtime.hemisphere.",),
    axes={"realtime.hemisphere.ground_scale": (0.0, 1.0)},
    ladder=({"realtime.diffuse": "hemisphere"},),
    package=__package__, fragment_glsl=("diffuse_hemisphere.glsl",),
    describe=describe,  # no rules against other choices: it goes with every other technique
)
