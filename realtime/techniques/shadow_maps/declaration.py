"""`realtime.occlusion = "shadow_maps"`: one depth map per light of the light array, declared as data
(scenes/model/technique_registry.py); the OpenGL half is shadow_maps.py. It reads the light array's
table ([realtime.lights] shadow_map_size) and shadows only the lobes the light array lights."""

from __future__ import annotations

from scenes.model.scene import MAX_SHADOW_TEXELS
from scenes.model.technique_registry import Declaration, combination_error
from scenes.storage.errors import SceneError


def validate(rt, given: dict, where: str) -> None:
    lights = rt.lights
    if rt.occlusion == "shadow_maps" and "lights" not in (rt.diffuse, rt.glossy):
        raise combination_error(rt, "occlusion", "diffuse", 'shadow maps are cast by the light array: set '
                                'realtime.diffuse or realtime.glossy = "lights"', where)
    if "shadow_map_size" in given.get("lights", {}) and rt.occlusion != "shadow_maps":
        raise SceneError(f"{where}: realtime.lights.shadow_map_size = {lights.shadow_map_size} with "
                         f"realtime.occlusion = {rt.occlusion!r}: shadow maps are drawn for "
                         'realtime.occlusion = "shadow_maps" only')
    texels = lights.count * lights.shadow_map_size ** 2
    if rt.occlusion == "shadow_maps" and texels > MAX_SHADOW_TEXELS:
        raise SceneError(f"{where}: realtime.lights.count = {lights.count} with realtime.lights.shadow_map_size = "
                         f"{lights.shadow_map_size}: {texels} shadow-map texels ({texels * 4 / 2**30:.2g} GiB); "
                         f"at most {MAX_SHADOW_TEXELS} (1 GiB): fewer lights or smaller maps")


def covers(lobe: str, rt) -> bool:
    return getattr(rt, lobe) == "lights"  # it shadows the light array only


DECLARATIONS = (
    Declaration(
        effect="occlusion", name="shadow_maps", rank=10, simulates=frozenset({"occlusion"}),
        implementation="realtime.techniques.shadow_maps.shadow_maps:ShadowMaps",
        timing_key="shadow",
        reads=("realtime.lights.shadow_map_size",),
        axes={"realtime.lights.shadow_map_size": (256, 1024)},
        package=__package__, fragment_glsl=("shadow_maps.glsl",),
        validate=validate, covers=covers,
    ),
)
