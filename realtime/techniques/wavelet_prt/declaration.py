"""`realtime.diffuse = "wavelet_prt"`, `occlusion = "wavelet_prt"`, `interreflection = "wavelet_prt"`: all-frequency
precomputed radiance transfer in a Haar wavelet basis with a non-linear lighting approximation (Ng, Ramamoorthi &
Hanrahan 2003), declared as data (scenes/model/technique_registry.py); the OpenGL half is wavelet_prt.py, the
precomputation wavelet_transfer.py, the derived settings settings.py. The three share [realtime.wavelet_prt],
with PRT's combination rules."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from realtime.techniques.wavelet_prt.settings import effective_settings
from scenes.model.technique_registry import (
    Declaration,
    combination_error,
    number,
    param,
    power_of_two,
    require_cube,
)
from scenes.storage.errors import SceneError

NAME = "wavelet_prt"
MAX_CUBE_SIZE = 128


@dataclass(frozen=True)
class WaveletPrt:
    """[realtime.wavelet_prt]: wavelet precomputed radiance transfer (wavelet_transfer.py, wavelet_prt.py)."""
    cube_size: int = param(32, power_of_two(8, MAX_CUBE_SIZE))  # face side of the lighting's cube level
    terms: int = param(256, number(1, 6 * MAX_CUBE_SIZE ** 2, integer=True))  # K lighting coefficients kept
    threshold: float = param(1e-4, number(0.0, 1.0))  # stored when >= threshold x the vertex's largest
    rays: int = param(256, number(1, 1 << 16, integer=True))  # hemisphere rays per vertex of the bounce gather
    bounces: int = param(0, number(0, 16, integer=True))  # interreflected bounces (>= 1 with interreflection)


def validate(rt, given: dict, where: str) -> None:
    w = rt.wavelet_prt
    if rt.occlusion == NAME and rt.diffuse != NAME:
        raise combination_error(rt, "occlusion", "diffuse", "precomputed visibility lives in the transfer: set "
                                f'realtime.diffuse = "{NAME}"', where)
    if rt.interreflection == NAME and (rt.diffuse != NAME or rt.occlusion != NAME):
        raise combination_error(rt, "interreflection", "occlusion", "interreflected transfer includes its "
                                f'shadowing: set realtime.diffuse = "{NAME}" and realtime.occlusion = "{NAME}"', where)
    if rt.interreflection == NAME and w.bounces < 1:
        raise SceneError(f"{where}: realtime.interreflection = '{NAME}' with realtime.wavelet_prt.bounces = "
                         f"{w.bounces}: interreflected transfer needs at least one bounce")
    if w.bounces > 0 and rt.interreflection != NAME:
        raise SceneError(f"{where}: realtime.wavelet_prt.bounces = {w.bounces} with realtime.interreflection = "
                         f"{rt.interreflection!r}: bounces are gathered for realtime.interreflection = \"{NAME}\" "
                         "only")
    if "rays" in given.get(NAME, {}) and rt.interreflection != NAME:
        raise SceneError(f"{where}: realtime.wavelet_prt.rays = {w.rays} with realtime.interreflection = "
                         f"{rt.interreflection!r}: the hemisphere rays gather bounces for realtime.interreflection "
                         f'= "{NAME}" only (visibility is one ray per cube texel)')
    if rt.diffuse != NAME:
        return
    require_cube(rt, "diffuse", where)
    coefficients = 6 * w.cube_size ** 2
    if w.terms > coefficients:
        raise SceneError(f"{where}: realtime.wavelet_prt.terms = {w.terms} with realtime.wavelet_prt.cube_size = "
                         f"{w.cube_size}: a cube of {w.cube_size}-texel faces has {coefficients} Haar coefficients "
                         f"(6 x cube_size^2); terms must be at most {coefficients}")
    if w.cube_size > rt.base_size:
        raise SceneError(f"{where}: realtime.wavelet_prt.cube_size = {w.cube_size} with realtime.base_size = "
                         f"{rt.base_size}: the lighting is a level of the environment's cube map, whose level-0 face "
                         f"has {rt.base_size} texels; cube_size must be at most realtime.base_size")


def validate_objects(rt, objects, where: str) -> None:
    two_sided = [i for i, o in enumerate(objects) if o.material.two_sided]
    if two_sided:
        i = two_sided[0]
        raise SceneError(f"{where}: realtime.diffuse = '{NAME}' with objects[{i}].material.two_sided = true: "
                         "precomputed transfer is computed for the front side only (its back would be shaded with "
                         "the front's transfer); use one-sided materials or another diffuse technique")


def describe(rt) -> dict:
    w = asdict(rt.wavelet_prt)
    if rt.interreflection != NAME:
        w.pop("rays")
        w.pop("bounces")
    return {NAME: w}


def row_label(techniques) -> str:
    w = techniques.get(NAME, {})
    return f"{NAME} {w.get('cube_size', '?')} K{w.get('terms', '?')}"


def diffuse_only(lobe: str, rt) -> bool:
    return lobe == "diffuse"  # only the diffuse lobe is transferred


_COMMON = dict(table=NAME, parameters=WaveletPrt,
               table_hint=f'realtime.diffuse, occlusion or interreflection = "{NAME}"',
               effective_settings=effective_settings)
DECLARATIONS = (
    Declaration(
        **_COMMON, effect="diffuse", name=NAME, rank=50, simulates=frozenset({"diffuse"}),
        implementation="realtime.techniques.wavelet_prt.wavelet_prt:WaveletDiffuse",
        timing_key="filter",  # this frame's Haar transform, selection and per-vertex sums
        reads=("realtime.wavelet_prt.cube_size", "realtime.wavelet_prt.terms", "realtime.wavelet_prt.threshold"),
        axes={"realtime.wavelet_prt.cube_size": (16, 32, 64),
              "realtime.wavelet_prt.terms": (16, 64, 256, 1024)},
        package=__package__, fragment_glsl=("diffuse_wavelet.glsl",), vertex_glsl=("wavelet_vertex.glsl",),
        vertex_entry="wavelet_vertex",
        validate=validate, validate_objects=validate_objects, describe=describe, row_label=row_label,
    ),
    Declaration(
        **_COMMON, effect="occlusion", name=NAME, rank=40, simulates=frozenset({"occlusion"}),
        implementation="realtime.techniques.wavelet_prt.wavelet_prt:WaveletOcclusion", covers=diffuse_only,
    ),
    Declaration(
        **_COMMON, effect="interreflection", name=NAME, rank=30, simulates=frozenset({"interreflection"}),
        implementation="realtime.techniques.wavelet_prt.wavelet_prt:WaveletInterreflection",
        reads=("realtime.wavelet_prt.rays", "realtime.wavelet_prt.bounces"),
        axes={"realtime.wavelet_prt.bounces": (1, 2)}, covers=diffuse_only,
    ),
)
