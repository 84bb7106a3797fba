"""The technique interface (design.md section 9): one small life cycle per real-time technique.

A technique simulates one effect of a scene (`diffuse`, `glossy`, later `occlusion`, ...) and is
chosen by a `[realtime]` key (`realtime.diffuse = "sh"`, `realtime.glossy = "prefiltered"`, ...):

    prepare(frame)      once per scene: precomputation, timed apart as `precompute`
    update(frame)       every frame: timed under the technique's own `timing_key`
    defines()           the #defines it adds to the shading pass (shade.frag includes its GLSL)
    bind(prog)          per frame, before the objects are drawn: textures, buffers, uniforms
    bind_object(prog, obj)   per object (e.g. the glossy LOD of that object's exponent)
    meta()              what it reports in Render.meta["techniques"]
    release()

`realtime.engine.frame.render` composes a frame from the techniques `choose(scene)` returns: only those for
the scene's effects are prepared, updated and compiled in (design.md section 4). The environment's
cube map and its 2x2 box chain (realtime.engine.gpu.EnvironmentFilter) are shared by every technique;
each says how much of the chain it reads (`chain_level`), so the paper's diffuse-only frame still
stops the chain at the selected level.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from importlib import import_module
from typing import Any, ClassVar

import moderngl

#: (effect key, value) -> "module:Class" of the technique (imported on use)
REGISTRY: dict[tuple[str, str], str] = {
    ("diffuse", "sh"): "realtime.techniques.sh.diffuse_sh:ShDiffuse",
    ("diffuse", "irradiance_map"): "realtime.techniques.irradiance_map.diffuse_irradiance_map:IrradianceMapDiffuse",
    ("glossy", "box"): "realtime.techniques.box.glossy_box:BoxGlossy",
    ("glossy", "prefiltered"): "realtime.techniques.prefiltered.glossy_prefiltered:PrefilteredGlossy",
    ("diffuse", "lights"): "realtime.techniques.lights.lights:DiffuseLights",
    ("glossy", "lights"): "realtime.techniques.lights.lights:GlossyLights",
    ("occlusion", "shadow_maps"): "realtime.techniques.shadow_maps.shadow_maps:ShadowMaps",
    ("diffuse", "prt"): "realtime.techniques.prt.prt:PrtDiffuse",
    ("occlusion", "prt"): "realtime.techniques.prt.prt:PrtOcclusion",
    ("interreflection", "prt"): "realtime.techniques.prt.prt:PrtInterreflection",
    ("occlusion", "vct"): "realtime.techniques.vct.vct:VctOcclusion",
    ("interreflection", "vct"): "realtime.techniques.vct.vct:VctInterreflection",
}
#: the scene keys that choose a technique, in the order frames run them
EFFECT_KEYS = ("diffuse", "glossy", "occlusion", "interreflection")
#: `none` choices: the effect is ignored (the paper ignores occlusion and interreflection)
NOTHING = "none"
#: `chain_level` of a technique that reads neither the cube map nor its chain (e.g. the light array)
NO_CUBE = -1


@dataclass
class Frame:
    """What every technique sees: the scene, the GL context, the shared environment filter, the
    selected mip level, and (in update) the environment's rotation of this frame."""

    ctx: moderngl.Context
    scene: Any
    env_filter: Any  # realtime.engine.gpu.EnvironmentFilter
    face_size: int
    level: int
    rotation_deg: float = 0.0
    number: int = 0  # the frame's index (warm-up frames included), for state shared between techniques
    shared: dict = field(default_factory=dict)  # e.g. the light array that diffuse, glossy and shadows read


class Technique:
    """Base class: a technique that needs nothing per frame (override what applies)."""

    effect: ClassVar[str]  # the scene key that chooses it: "diffuse", "glossy", ...
    name: ClassVar[str]  # its value of that key: "sh", "box", ...
    simulates: ClassVar[frozenset[str]]  # the scene effects it simulates
    timing_key: ClassVar[str] = "filter"  # its per-frame key in Render.timings
    #: keys of parts of its update it times itself (split_timings), reported apart from timing_key
    extra_timing_keys: ClassVar[tuple[str, ...]] = ()
    #: the scene keys only this technique reads ("realtime.table." covers a whole table): a sweep
    #: varies them only where the technique runs (experiments/runs/sweep.py)
    reads: ClassVar[tuple[str, ...]] = ()
    #: of those, the axes worth sweeping, with values that show the trade-off (`iblcheck sweep
    #: --technique-axes` sweeps them, with the technique choices of the scene's effects)
    axes: ClassVar[dict[str, tuple]] = {}

    def __init__(self, frame: Frame) -> None:
        self.frame = frame

    @classmethod
    def covers(cls, lobe: str, scene) -> bool:
        """For an occlusion or interreflection technique: whether it reaches this lobe's light
        ("diffuse" or "glossy") with the scene's other choices (e.g. PRT shadows diffuse light only)."""
        return True

    def chain_level(self, frame: Frame) -> int | None:
        """The coarsest level of the environment's box chain it reads (None: the whole chain; NO_CUBE:
        not even the cube map: a frame whose techniques all say so skips building it)."""
        return frame.level

    def prepare(self, frame: Frame) -> None:  # noqa: B027 (optional hook)
        """Once per scene, before the first frame (timed as `precompute`)."""

    def update(self, frame: Frame) -> None:  # noqa: B027 (optional hook)
        """Every frame, after the environment's cube map and chain are rebuilt."""

    def defines(self) -> tuple[str, ...]:
        return ()

    def split_timings(self) -> dict[str, float]:
        """After update: {extra timing key: ms} of the parts of this update timed apart (they are
        taken out of timing_key's time, so the frame's total is unchanged)."""
        return {}

    def bind(self, prog: moderngl.Program) -> None:  # noqa: B027 (optional hook)
        """Per frame, before the objects are drawn."""

    def bind_object(self, prog: moderngl.Program, obj) -> None:  # noqa: B027 (optional hook)
        """Per object, before it is drawn."""

    def meta(self) -> dict:
        return {}

    def release(self) -> None:  # noqa: B027 (optional hook)
        pass


def set_uniform(prog: moderngl.Program, name: str, value) -> None:
    """Set a uniform if the compiled program kept it (unused ones are optimised away)."""
    if name in prog:
        prog[name] = value


def technique_class(effect: str, value: str) -> type[Technique]:
    module, _, cls = REGISTRY[(effect, value)].partition(":")
    return getattr(import_module(module), cls)


def owner_of(key: str) -> tuple[str, str] | None:
    """The (effect key, value) of the technique that alone reads scene `key`, or None."""
    for pair in REGISTRY:
        for k in technique_class(*pair).reads:
            if key == k or (k.endswith(".") and key.startswith(k)):
                return pair
    return None


def chosen(scene) -> dict[str, str]:
    """{effect key: chosen value} for the scene's [realtime] technique keys."""
    rt = scene.realtime
    return {key: getattr(rt, key) for key in EFFECT_KEYS}


def needed(scene) -> list[tuple[str, str]]:
    """The (effect key, value) pairs this scene runs: a technique only for an effect the scene has."""
    effects = scene.effects
    return [(key, value) for key, value in chosen(scene).items() if value != NOTHING and key in effects]


def choose(scene, frame: Frame) -> list[Technique]:
    """The techniques of a scene, constructed (not yet prepared)."""
    return [technique_class(key, value)(frame) for key, value in needed(scene)]


def simulated_effects(scene) -> frozenset[str]:
    """The effects the scene's chosen techniques simulate (Fresnel is the shading pass's own)."""
    out = {"fresnel"}
    for key, value in needed(scene):
        out |= technique_class(key, value).simulates
    return frozenset(out)


def unsimulated_effects(scene) -> list[str]:
    """Effects the scene calls for that its techniques do not simulate (design.md section 9): a low
    PSNR there is a missing effect, not a bug. An occlusion or interreflection technique that reaches
    only one lobe adds the other as e.g. "glossy occlusion" (PRT shadows the diffuse light only)."""
    missing = sorted(scene.effects - simulated_effects(scene))
    for key, value in needed(scene):
        if key in ("occlusion", "interreflection"):
            cls = technique_class(key, value)
            missing += [f"{lobe} {key}" for lobe in ("diffuse", "glossy")
                        if lobe in scene.effects and not cls.covers(lobe, scene)]
    return missing


def describe(scene) -> dict[str, Any]:
    """The techniques and their parameters as a plain dict (render meta, result rows)."""
    rt = scene.realtime
    out: dict[str, Any] = {"parameterization": rt.parameterization, "face_size": rt.face_size,
                           "base_size": rt.base_size}
    if rt.parameterization == "sphere_map":
        capture = rt.sphere_map.capture
        out["sphere_map"] = {"capture": capture if isinstance(capture, str) else list(capture)}
    out["reflection"] = rt.reflection
    for key, value in chosen(scene).items():
        out[key] = value
    if rt.diffuse == "sh":
        out["sh_order"], out["sh_window"] = rt.sh_order, rt.sh_window
    if rt.diffuse == "irradiance_map":
        out["irradiance_map"] = vars(rt.irradiance_map).copy()
    if rt.glossy == "box":
        out["lod_bias"], out["lod_mapping"] = rt.lod_bias, rt.lod_mapping
    if rt.glossy == "prefiltered":
        out["prefiltered"] = vars(rt.prefiltered).copy()
    if "lights" in (rt.diffuse, rt.glossy):
        lights = vars(rt.lights).copy()
        if rt.occlusion != "shadow_maps":
            lights.pop("shadow_map_size")
        out["lights"] = lights
    if "vct" in (rt.occlusion, rt.interreflection):
        out["vct"] = vars(rt.vct).copy()
    if rt.diffuse == "prt":
        prt = vars(rt.prt).copy()
        if rt.occlusion != "prt":
            prt.pop("rays")
        out["prt"] = prt
    return out
