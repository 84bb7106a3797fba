"""`realtime.diffuse = "lights"` and `realtime.glossy = "lights"`: the environment as an array of distant
lights (scenes/environment/light_array.py), declared as data (scenes/model/technique_registry.py); the
OpenGL half is lights.py. Both lobes read one table, [realtime.lights]."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from scenes.environment import light_array
from scenes.model.technique_registry import Declaration, number, one_of, param, power_of_two
from scenes.storage.errors import SceneError


@dataclass(frozen=True)
class Lights:
    """[realtime.lights]: the light array (scenes/environment/light_array.py, lights.py)."""
    count: int = param(42, number(1, 65536, integer=True))  # geodesic: a subdivided polyhedron's vertex count;
    # median_cut: a power of two
    placement: str = param("geodesic", one_of("geodesic", "median_cut"))
    shadow_map_size: int = param(512, power_of_two(16, 8192))  # one depth map per light (occlusion = "shadow_maps")


def validate(rt, given: dict, where: str) -> None:
    lights = rt.lights
    if "lights" in (rt.diffuse, rt.glossy):
        problem = light_array.count_problem(lights.placement, lights.count)
        if problem:
            raise SceneError(f"{where}: realtime.lights.count = {lights.count} with realtime.lights.placement = "
                             f"{lights.placement!r}: {problem}")


def describe(rt) -> dict:
    lights = asdict(rt.lights)
    if rt.occlusion != "shadow_maps":
        lights.pop("shadow_map_size")
    return {"lights": lights}


_COMMON = dict(
    implementation="", table="lights", parameters=Lights, table_hint='realtime.diffuse or realtime.glossy = "lights"',
    timing_key="lights",
    reads=("realtime.lights.count", "realtime.lights.placement"),
    axes={"realtime.lights.count": (4, 12, 42, 162, 642), "realtime.lights.placement": ("geodesic",)},
    package=__package__, fragment_glsl=("lights.glsl",), describe=describe,
)
DECLARATIONS = (
    Declaration(**{**_COMMON, "implementation": "realtime.techniques.lights.lights:DiffuseLights"},
                effect="diffuse", name="lights", rank=30, simulates=frozenset({"diffuse"}), validate=validate),
    Declaration(**{**_COMMON, "implementation": "realtime.techniques.lights.lights:GlossyLights"},
                effect="glossy", name="lights", rank=30, simulates=frozenset({"glossy"})),
)
