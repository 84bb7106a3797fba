"""`realtime.diffuse = "irradiance_map"`: the exact cosine convolution of the environment into a cube map,
declared as data (scenes/model/technique_registry.py); the OpenGL half is diffuse_irradiance_map.py."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from scenes.model.technique_registry import Declaration, param, power_of_two, require_cube
from scenes.storage.errors import SceneError


@dataclass(frozen=True)
class IrradianceMap:
    """[realtime.irradiance_map]: the exact cosine convolution into a cube map (irradiance_convolution.py)."""
    size: int = param(32, power_of_two(1, 256))  # face size of the irradiance cube map
    source_size: int = param(32, power_of_two(1, 256))  # face size of the mip level that is convolved


def validate(rt, given: dict, where: str) -> None:
    if rt.diffuse != "irradiance_map":
        return
    require_cube(rt, "diffuse", where)  # it convolves the cube map
    m = rt.irradiance_map  # its default source (32) must not stop a small base_size the map does not read
    if m.source_size > rt.base_size:
        raise SceneError(f"{where}: realtime.irradiance_map.source_size = {m.source_size}: must be at most "
                         f"realtime.base_size = {rt.base_size}")


def describe(rt) -> dict:
    return {"irradiance_map": asdict(rt.irradiance_map)}



def row_label(t) -> str:
    """'irradiance map 32 from 32' (its face size, from the source level's)."""
    m = t.get("irradiance_map", {})
    return f"irradiance map {m.get('size')} from {m.get('source_size')}"

DECLARATIONS = (
    Declaration(
        effect="diffuse", name="irradiance_map", rank=20, simulates=frozenset({"diffuse"}),
        implementation="realtime.techniques.irradiance_map.diffuse_irradiance_map:IrradianceMapDiffuse",
        table="irradiance_map", parameters=IrradianceMap, table_hint='realtime.diffuse = "irradiance_map"',
        timing_key="irradiance",
        reads=("realtime.irradiance_map.",),
        axes={"realtime.irradiance_map.size": (16, 32, 64), "realtime.irradiance_map.source_size": (16, 32)},
        package=__package__, fragment_glsl=("diffuse_irradiance_map.glsl",),
        validate=validate, describe=describe, row_label=row_label,
        # E(n) is the material's business: any Lambert term, the paper's kd / pi or glTF's base_color / pi
        materials=frozenset({"diffuse", "blend", "pbr"}),
    ),
)
