"""The technique interface: one small life cycle per real-time technique (docs/architecture.md).

A technique simulates one effect of a scene (`diffuse`, `glossy`, `occlusion`, `interreflection`) and is
chosen by a `[realtime]` key (`realtime.diffuse = "sh"`, `realtime.glossy = "prefiltered"`, ...). What it
is (its choice, what it simulates, its parameters and rules, its timing keys, its GLSL, what it reports)
is declared as data in its package (scenes/model/technique_registry.py, `Declaration`) and found through
the entry-point group `iblcheck.techniques`, builtins and plugins alike. Its OpenGL half, a `Technique`
subclass named by the declaration, runs it:

    prepare(frame)      once per scene: precomputation, timed apart as `precompute`
    update(frame)       every frame: timed under the declaration's `timing_key`
    defines()           the #defines it adds to the shading pass (which includes its declared GLSL)
    bind(prog)          per frame, before the objects are drawn: textures, buffers, uniforms
    bind_object(prog, obj)   per object (e.g. the glossy LOD of that object's exponent)
    meta()              what it reports in Render.meta["techniques"]
    release()

`realtime.engine.frame.render` composes a frame from the techniques `choose(scene)` returns: only those for
the scene's effects are prepared, updated and compiled in, and of those only the ones whose `has_work(frame)`
says they have something to do (default: yes). A technique the scene chose that does not run (the scene
calls for no such effect, or it has no work) is said in one `warning:` line and recorded under `not_run` in
the techniques' description (`describe`, `not_run`): what is reported is what ran.

The environment's cube map and its 2x2 box chain (realtime.engine.gpu.EnvironmentFilter) are shared by every
technique; each says how much of the chain it reads (`chain_level`), so the paper's diffuse-only frame still
stops the chain at the selected level.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any

from scenes.model import technique_registry
from scenes.model.technique_registry import EFFECT_KEYS, NOTHING, OPTIONAL_EFFECTS, Declaration
from scenes.storage.errors import PluginDeclarationError

if TYPE_CHECKING:  # the interface is importable without OpenGL; only the techniques' modules need it
    import moderngl

class UnsimulatedEffectWarning(UserWarning):
    """The scene calls for an effect that the chosen techniques do not simulate."""


__all__ = ["UnsimulatedEffectWarning", "EFFECT_KEYS", "NOTHING", "NO_CUBE", "Frame", "Technique", "build", "choose",
           "declaration_of", "describe", "needed", "not_run", "owner_of", "pairs", "simulated_effects",
           "unsimulated_effects"]

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
    """Base class: a technique that needs nothing per frame (override what applies). What it is chosen by,
    simulates and reads is its declaration's (`self.declaration`, set by `choose`)."""

    declaration: Declaration

    @property
    def timing_key(self) -> str:
        return self.declaration.timing_key

    @property
    def extra_timing_keys(self) -> tuple[str, ...]:
        return self.declaration.extra_timing_keys

    def __init__(self, frame: Frame) -> None:
        self.frame = frame

    def chain_level(self, frame: Frame) -> int | None:
        """The coarsest level of the environment's box chain it reads (None: the whole chain; NO_CUBE:
        not even the cube map: a frame whose techniques all say so skips building it)."""
        return frame.level

    def prepare(self, frame: Frame) -> None:  # noqa: B027 (optional hook)
        """Once per scene, before the first frame (timed as `precompute`)."""

    def update(self, frame: Frame) -> None:  # noqa: B027 (optional hook)
        """Every frame, after the environment's cube map and chain are rebuilt."""

    def has_work(self, frame: Frame) -> bool:
        """Whether this technique has anything to do in `frame`'s scene (asked once, before `prepare`).
        False: it is neither prepared nor compiled in, and the render says so and records it as not run.

        Asked only of the techniques of effects the scene calls for (`needed`) that may be left out
        (OPTIONAL_EFFECTS: occlusion, interreflection); a lobe the scene calls for (diffuse, glossy) is
        always shaded by its technique. The default is True."""
        return True

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


def pairs() -> list[tuple[str, str]]:
    """Every registered (effect key, value), builtins first."""
    return [(d.effect, d.name) for d in technique_registry.declarations()]


def declaration_of(effect: str, value: str) -> Declaration:
    """The declaration of `realtime.<effect> = "<value>"`: its `simulates`, `reads`, `axes`, `ladder`, ..."""
    return technique_registry.lookup(effect, value)


def owner_of(key: str) -> tuple[str, str] | None:
    """The (effect key, value) of the technique that alone reads scene `key`, or None."""
    for d in technique_registry.declarations():
        for k in d.reads:
            if key == k or (k.endswith(".") and key.startswith(k)):
                return d.effect, d.name
    return None


def chosen(scene) -> dict[str, str]:
    """{effect key: chosen value} for the scene's [realtime] technique keys."""
    rt = scene.realtime
    return {key: getattr(rt, key) for key in EFFECT_KEYS}


def needed(scene) -> list[tuple[str, str]]:
    """The (effect key, value) pairs this scene runs: a technique only for an effect the scene has."""
    effects = scene.effects
    return [(key, value) for key, value in chosen(scene).items() if value != NOTHING and key in effects]


def not_run(scene) -> dict[str, str]:
    """{effect key: reason} of the scene's technique choices that do not run because the scene calls for
    no such effect (e.g. `occlusion = "vct"` with one convex object, which shadows nothing).

    A key left at the engine's default (`glossy = "box"` on a diffuse-only scene) is the engine's standing
    choice, not the scene's, and is not listed; neither is `"none"`."""
    defaults = {f.name: f.default for f in fields(scene.realtime)}
    return {key: f"the scene calls for no {key}" for key, value in chosen(scene).items()
            if value != NOTHING and key not in scene.effects and value != defaults.get(key)}


def without_work(techniques: list[Technique], frame: Frame) -> list[Technique]:
    """The techniques of optional effects whose `has_work(frame)` says they have nothing to do."""
    return [t for t in techniques if t.declaration.effect in OPTIONAL_EFFECTS and not t.has_work(frame)]


def choose(scene, frame: Frame) -> list[Technique]:
    """The techniques of a scene, constructed (not yet prepared)."""
    return [build(key, value, frame) for key, value in needed(scene)]


def build(effect: str, value: str, frame: Frame) -> Technique:
    """The technique of `realtime.<effect> = "<value>"`, constructed with its declaration."""
    decl = declaration_of(effect, value)
    cls = decl.load()
    if not (isinstance(cls, type) and issubclass(cls, Technique)):
        raise PluginDeclarationError(f"{decl.label}: implementation {decl.implementation!r} is not a subclass of "
                                     "realtime.engine.technique.Technique")
    technique = cls(frame)
    technique.declaration = decl
    return technique


def simulated_effects(scene) -> frozenset[str]:
    """The effects the scene's chosen techniques simulate (Fresnel is the shading pass's own)."""
    out = {"fresnel"}
    for key, value in needed(scene):
        out |= declaration_of(key, value).simulates
    return frozenset(out)


def unsimulated_effects(scene) -> list[str]:
    """Effects the scene calls for that its techniques do not simulate: a low PSNR there is a missing
    effect, not a bug. A technique that reaches only one lobe (its declaration's `covers`) adds the other
    as e.g. "glossy occlusion" (PRT shadows the diffuse light only)."""
    missing = sorted(scene.effects - simulated_effects(scene))
    for key, value in needed(scene):
        decl = declaration_of(key, value)
        if decl.covers is not None:
            missing += [f"{lobe} {key}" for lobe in ("diffuse", "glossy")
                        if lobe in scene.effects and not decl.call("covers", lobe, scene.realtime)]
    return missing


def describe(scene) -> dict[str, Any]:
    """The techniques and their parameters as a plain dict (render meta, result rows): the engine's
    settings, the choices, then what each chosen technique's declaration describes."""
    rt = scene.realtime
    out: dict[str, Any] = {"parameterization": rt.parameterization, "face_size": rt.face_size,
                           "base_size": rt.base_size}
    if rt.parameterization == "sphere_map":
        capture = rt.sphere_map.capture
        out["sphere_map"] = {"capture": capture if isinstance(capture, str) else list(capture)}
    out["reflection"] = rt.reflection
    for key, value in chosen(scene).items():
        out[key] = value
    for decl in technique_registry.chosen(rt):
        if decl.describe is not None:
            out.update(decl.call("describe", rt))
    idle = not_run(scene)
    if idle:  # only then: the description of a scene whose choices all run is unchanged
        out["not_run"] = idle
    return out
