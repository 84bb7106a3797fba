"""`realtime.diffuse = "prt"`, `occlusion = "prt"`, `interreflection = "prt"`: precomputed radiance transfer,
declared as data (scenes/model/technique_registry.py); the OpenGL half is prt.py, the precomputation
prt_transfer.py, the derived settings settings.py. The three share [realtime.prt]."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from realtime.techniques.prt.settings import effective_settings
from scenes.model.technique_registry import Declaration, combination_error, number, param
from scenes.storage.errors import SceneError


@dataclass(frozen=True)
class Prt:
    """[realtime.prt]: precomputed radiance transfer (prt_transfer.py, prt.py)."""
    order: int = param(2, number(2, 8, integer=True))  # SH order of the transfer (2: 9 coefficients ... 8: 81)
    rays: int = param(256, number(1, 1 << 16, integer=True))  # visibility rays per vertex (occlusion = "prt")
    bounces: int = param(0, number(0, 16, integer=True))  # interreflected bounces (>= 1 with interreflection)


def validate(rt, given: dict, where: str) -> None:
    prt = rt.prt
    if rt.occlusion == "prt" and rt.diffuse != "prt":
        raise combination_error(rt, "occlusion", "diffuse", "precomputed visibility lives in the transfer: set "
                                'realtime.diffuse = "prt"', where)
    if rt.interreflection == "prt" and (rt.diffuse != "prt" or rt.occlusion != "prt"):
        raise combination_error(rt, "interreflection", "occlusion", "interreflected transfer includes its "
                                'shadowing: set realtime.diffuse = "prt" and realtime.occlusion = "prt"', where)
    if rt.interreflection == "prt" and prt.bounces < 1:
        raise SceneError(f"{where}: realtime.interreflection = 'prt' with realtime.prt.bounces = {prt.bounces}: "
                         "interreflected transfer needs at least one bounce")
    if prt.bounces > 0 and rt.interreflection != "prt":
        raise SceneError(f"{where}: realtime.prt.bounces = {prt.bounces} with realtime.interreflection = "
                         f"{rt.interreflection!r}: bounces are gathered for realtime.interreflection = \"prt\" only")
    if "rays" in given.get("prt", {}) and rt.occlusion != "prt":
        raise SceneError(f"{where}: realtime.prt.rays = {prt.rays} with realtime.occlusion = {rt.occlusion!r}: "
                         'visibility rays are traced for realtime.occlusion = "prt" only (unshadowed transfer is '
                         "exact)")


def validate_objects(rt, objects, where: str) -> None:
    two_sided = [i for i, o in enumerate(objects) if o.material.two_sided]
    if two_sided:
        i = two_sided[0]
        raise SceneError(f"{where}: realtime.diffuse = 'prt' with objects[{i}].material.two_sided = true: precomputed "
                         "transfer is computed for the front side only (its back would be shaded with the front's "
                         "transfer); use one-sided materials or another diffuse technique")


def describe(rt) -> dict:
    prt = asdict(rt.prt)
    if rt.occlusion != "prt":
        prt.pop("rays")
    return {"prt": prt}


def diffuse_only(lobe: str, rt) -> bool:
    return lobe == "diffuse"  # only the diffuse lobe is transferred


_COMMON = dict(table="prt", parameters=Prt, table_hint='realtime.diffuse, occlusion or interreflection = "prt"',
               effective_settings=effective_settings)
DECLARATIONS = (
    Declaration(
        **_COMMON, effect="diffuse", name="prt", rank=40, simulates=frozenset({"diffuse"}),
        implementation="realtime.techniques.prt.prt:PrtDiffuse",
        timing_key="filter",  # this frame's SH projection, like the paper's SH9
        reads=("realtime.prt.order",), axes={"realtime.prt.order": (2, 3, 4)},
        package=__package__, fragment_glsl=("diffuse_prt.glsl",), vertex_glsl=("prt_vertex.glsl",),
        vertex_entry="prt_vertex",
        validate=validate, validate_objects=validate_objects, describe=describe,
    ),
    Declaration(
        **_COMMON, effect="occlusion", name="prt", rank=20, simulates=frozenset({"occlusion"}),
        implementation="realtime.techniques.prt.prt:PrtOcclusion",
        reads=("realtime.prt.rays",), axes={"realtime.prt.rays": (64, 256, 1024)}, covers=diffuse_only,
    ),
    Declaration(
        **_COMMON, effect="interreflection", name="prt", rank=10, simulates=frozenset({"interreflection"}),
        implementation="realtime.techniques.prt.prt:PrtInterreflection",
        reads=("realtime.prt.bounces",), axes={"realtime.prt.bounces": (1, 2)}, covers=diffuse_only,
    ),
)
