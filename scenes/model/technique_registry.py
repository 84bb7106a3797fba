"""The technique registry: every real-time technique, builtin or from another installed package, found
through its declaration in the entry-point group `iblcheck.techniques` (docs/architecture.md, "The
technique interface").

A technique package declares, as plain data importable without OpenGL (`Declaration`): the scene key it
is chosen by (`effect`: "diffuse", "glossy", "occlusion" or "interreflection") and its value of that key
(`name`), the effects it simulates, its parameters (a frozen dataclass for its `[realtime.<table>]`
table and one for the keys it reads flat in `[realtime]`, each field with its default and its check,
made with `param`), its rules against other choices (`validate`), its timing keys, what a sweep varies
(`reads`, `axes`, `ladder`), its GLSL and the settings it reports (`describe`). The OpenGL class that
runs it is named by "module:Class" (`implementation`) and imported only when a frame runs it.

iblcheck registers its own techniques exactly as a plugin does, one line per package in its
pyproject.toml:

    [project.entry-points."iblcheck.techniques"]
    sh = "realtime.techniques.sh.declaration:DECLARATIONS"

An entry point names one `Declaration` or a sequence of them (one package may declare several: the light
array is both `diffuse = "lights"` and `glossy = "lights"`). By convention its name is the technique's
name, so that a scene choosing a plugin that failed to load is told why.

Declarations are loaded once per process, builtins (the `iblcheck` distribution) first by their `rank`
(the order of the choices in the scene format), then plugins sorted by entry-point name. A plugin that
cannot be imported or whose declaration is wrong is left out with its one-line error (`broken()`); the
builtins still work, and a scene that chooses it gets that error (`PluginLoadError`, exit 3, or
`PluginDeclarationError`, exit 2).
This module imports no technique statically (scenes may not import realtime).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache
from importlib import import_module, metadata, resources
from typing import Any

from scenes.model import materials
from scenes.storage.errors import (
    InputError,
    MissingCapability,
    PluginDeclarationError,
    PluginError,
    PluginLoadError,
    SceneError,
)

GROUP = "iblcheck.techniques"
#: the distribution whose techniques are builtins
BUILTIN_DISTRIBUTION = "iblcheck"
#: the scene keys that choose a technique, in the order frames run them
EFFECT_KEYS = ("diffuse", "glossy", "occlusion", "interreflection")
#: the choice of no technique: the effect is ignored (allowed for occlusion and interreflection only)
NOTHING = "none"
#: timing keys the frame itself reports: a technique's would corrupt them
RESERVED_TIMING_KEYS = frozenset({"draw", "total", "precompute", "background", "frame"})
#: the effect keys that may choose NOTHING
OPTIONAL_EFFECTS = ("occlusion", "interreflection")

Check = tuple[Callable[[Any], Any], str]
#: the material types a technique shades unless it declares others: the paper's
PAPER_MATERIALS = frozenset(materials.PAPER_TYPES)  # (value -> checked value or None, what is allowed)


# --------------------------------------------------------------------------- parameter checks
# Each check returns the normalised value, or None when the value is not allowed; its text says
# what is allowed ("must be <text>" in the error).


def number(lo: float, hi: float, lo_open: bool = False, hi_open: bool = False, integer: bool = False) -> Check:
    """A number (an integer with `integer`) in [lo, hi], the ends open with lo_open / hi_open. An integer's
    bounds are written out whole (2^24 as 16777216, which `:g` writes 1.67772e+07: not the bound)."""
    lb = "(" if lo_open else "["
    rb = ")" if hi_open else "]"
    ends = f"{int(lo)}, {int(hi)}" if integer else f"{lo:g}, {hi:g}"
    text = f"{'an integer' if integer else 'a number'} in {lb}{ends}{rb}"

    def check(v):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or (integer and not isinstance(v, int)):
            return None
        if not math.isfinite(v):
            return None
        if (v < lo or v > hi) or (lo_open and v == lo) or (hi_open and v == hi):
            return None
        return int(v) if integer else float(v)

    return check, text


def power_of_two(lo: int, hi: int, allow_auto: bool = False) -> Check:
    """An integer power of two in [lo, hi] (or "auto" with allow_auto)."""
    text = f"a power of two in [{lo}, {hi}]" + (' or "auto"' if allow_auto else "")

    def check(v):
        if allow_auto and v == "auto":
            return v
        if isinstance(v, bool) or not isinstance(v, int) or v < lo or v > hi or v & (v - 1):
            return None
        return v

    return check, text


def one_of(*choices) -> Check:
    """One of the given strings."""
    def check(v):
        return v if v in choices else None

    return check, "one of " + ", ".join(f'"{c}"' for c in choices)


def int_choice(*choices: int) -> Check:
    """One of the given integers."""
    def check(v):
        return v if isinstance(v, int) and not isinstance(v, bool) and v in choices else None

    return check, "one of " + ", ".join(str(c) for c in choices)


def param(default: Any, check: Check) -> Any:
    """A parameter of a technique's dataclass: its default and its check (kept in the field's metadata)."""
    return field(default=default, metadata={"check": check})


def parameter_checks(cls: type | None) -> dict[str, Check]:
    """{key: check} of a parameter dataclass (its fields made with `param`)."""
    return {} if cls is None else {f.name: f.metadata["check"] for f in dataclasses.fields(cls)}


def parameter_defaults(cls: type | None) -> dict[str, Any]:
    return {} if cls is None else {f.name: f.default for f in dataclasses.fields(cls)}


# --------------------------------------------------------------------------- the declaration


@dataclass(frozen=True)
class Declaration:
    """One technique: what it is chosen by, what it simulates and reads, its rules and its GLSL.

    The hooks are plain functions of the scene's `Realtime` (`rt`, read by attribute:
    `rt.diffuse`, `rt.sh_order`, `rt.lights.count`):

    validate(rt, given, where)   raises SceneError naming both keys for a combination that makes no sense;
                                 called for every registered technique, chosen or not (a key of one
                                 technique set while another is chosen is such a combination). `given`
                                 holds the keys the scene file set: the flat ones, and each table's as
                                 given[table].
    validate_objects(rt, objects, where)   the same against the scene's objects (only when chosen)
    describe(rt) -> dict         its settings for render metadata and result rows (only when chosen)
    covers(lobe, rt) -> bool     an occlusion or interreflection technique: whether it reaches that
                                 lobe's light ("diffuse" or "glossy") with the other choices
    effective_settings(scene)    the settings it actually runs with, where they are derived

    GLSL (files in the technique's own package, `#include "x"` resolved there first, then in
    realtime/shaders/): `fragment_glsl` goes into shade.frag; a diffuse technique defines
    `vec3 diffuse_irradiance(vec3 n)`, a glossy one `vec3 glossy_radiance(vec3 r)`; `shade_entry` names
    a `void f(vec3 n, vec3 v, inout vec3 Ld, inout vec3 Lg)` called after both lobes (occlusion,
    interreflection). `vertex_glsl` goes into shade.vert, with `vertex_entry` a `void f()` called
    per vertex.
    """

    effect: str
    name: str
    simulates: frozenset[str]
    implementation: str  # "module:Class" of its OpenGL class (realtime.engine.technique.Technique)
    table: str | None = None  # its [realtime.<table>] table (several techniques of one package may share it)
    parameters: type | None = None  # the table's frozen dataclass (fields made with `param`)
    flat: type | None = None  # the keys it reads flat in [realtime] (sh_order, lod_bias): a dataclass too
    #: where its choice is listed among its effect's choices (error messages, sweeps): builtins by rank in
    #: the scene format's order, plugins after every builtin, by entry-point name
    rank: int = 1000
    timing_key: str = "filter"  # its per-frame key in Render.timings
    extra_timing_keys: tuple[str, ...] = ()  # parts of its update it times apart
    #: the scene keys only this technique reads ("realtime.table." covers a whole table): a sweep
    #: varies them only where the technique runs
    reads: tuple[str, ...] = ()
    #: of those, the axes worth sweeping (`iblcheck sweep --technique-axes`)
    axes: Mapping[str, tuple] = field(default_factory=dict)
    #: override points the accuracy/time ladder runs for a plugin technique ({"realtime.diffuse": "x"}, ...)
    ladder: tuple[dict, ...] = ()
    #: for `table_hint`: the choices that read its table, as the error names them
    table_hint: str = ""
    package: str = ""  # the package holding its GLSL (importlib.resources)
    fragment_glsl: tuple[str, ...] = ()
    vertex_glsl: tuple[str, ...] = ()
    shade_entry: str | None = None
    vertex_entry: str | None = None
    validate: Callable | None = None
    validate_objects: Callable | None = None
    describe: Callable | None = None
    #: row_label(techniques) -> str: the technique with its main parameter, from a row's `techniques`
    #: dict (describe's output), for tables and plots; without it, its name
    row_label: Callable | None = None
    covers: Callable | None = None
    effective_settings: Callable | None = None
    #: the material types (scenes/model/materials.py) whose lobes it shades; None: the paper's own
    #: (diffuse, phong, blend), whose Phong lobe and kd it is written for
    materials: frozenset[str] | None = None
    #: bump when what the technique computes changes for the same settings (a corrected estimator): it enters
    #: the ids of the result rows that run it, so that stored rows made before are recomputed, not reused;
    #: 0 leaves it out of the ids (rows made before it was set keep theirs)
    model_version: int = 0
    # filled in by the registry
    distribution: str = ""  # the distribution that registered it ("iblcheck" for builtins)
    entry_point: str = ""
    builtin: bool = False

    @property
    def choice(self) -> str:
        return f'realtime.{self.effect} = "{self.name}"'

    def call(self, hook: str, *args: Any) -> Any:
        """Its hook `hook` (validate, describe, covers, ...) applied to `args`. A plugin's hook that fails
        other than by refusing the scene (an InputError) is the plugin's bug: one line naming the plugin
        (PluginLoadError, exit 3), never a traceback, so a broken plugin cannot take a builtin down."""
        fn = getattr(self, hook)
        if self.builtin:
            return fn(*args)
        try:
            return fn(*args)
        except InputError:
            raise
        except Exception as exc:
            raise PluginLoadError(f"{self.label}: its {hook} hook failed: {type(exc).__name__}: "
                                  f"{_one_line(exc)}") from None

    def load(self) -> type:
        """Its OpenGL class (imports it, and so moderngl)."""
        module, _, cls = self.implementation.partition(":")
        try:
            return getattr(import_module(module), cls)
        except Exception as exc:  # any failure of a plugin's module is its own, reported in one line
            if self.builtin:
                raise
            raise PluginLoadError(f"{self.label}: cannot import its implementation {self.implementation!r}: "
                                  f"{type(exc).__name__}: {_one_line(exc)}") from None

    @property
    def label(self) -> str:
        """How errors name it: the plugin's distribution and entry point."""
        return f"technique plugin {self.distribution!r} (entry point {GROUP}:{self.entry_point})"


# --------------------------------------------------------------------------- loading


@dataclass(frozen=True)
class Broken:
    """A plugin entry point that could not be registered."""

    distribution: str
    entry_point: str
    error: PluginError


@dataclass(frozen=True)
class Registry:
    declarations: tuple[Declaration, ...]
    broken: tuple[Broken, ...]


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _entry_points() -> list[metadata.EntryPoint]:
    """The group's entry points: builtins first in their file order, then plugins by name."""
    eps = list(metadata.entry_points(group=GROUP))
    builtin = [ep for ep in eps if ep.dist is not None and ep.dist.name == BUILTIN_DISTRIBUTION]
    plugins = sorted((ep for ep in eps if ep not in builtin), key=lambda ep: (ep.name, _dist(ep)))
    return builtin + plugins


def _dist(ep: metadata.EntryPoint) -> str:
    return ep.dist.name if ep.dist is not None else "?"


@cache
def registry() -> Registry:
    """Every declaration, loaded once per process (see the module docstring)."""
    out: list[Declaration] = []
    broken: list[Broken] = []
    seen_eps: set[tuple[str, str]] = set()
    for ep in _entry_points():
        dist = _dist(ep)
        if (dist, ep.name) in seen_eps:  # the same distribution found twice on the path: its first copy
            continue
        seen_eps.add((dist, ep.name))
        builtin = dist == BUILTIN_DISTRIBUTION
        label = f"technique plugin {dist!r} (entry point {GROUP}:{ep.name})"
        try:
            try:
                value = ep.load()
            except Exception as exc:  # a plugin's import may fail in any way: one line, never a traceback
                raise PluginLoadError(f"{label}: cannot be imported: {type(exc).__name__}: {_one_line(exc)}") \
                    from None
            decls = [value] if isinstance(value, Declaration) else value
            if not isinstance(decls, Sequence) or not decls or \
                    not all(isinstance(d, Declaration) for d in decls):
                raise PluginDeclarationError(f"{label}: must name a Declaration or a sequence of them "
                                             f"(scenes.model.technique_registry), got {type(value).__name__}")
            decls = [dataclasses.replace(d, distribution=dist, entry_point=ep.name, builtin=builtin) for d in decls]
            for d in decls:
                check_declaration(d, label, out)
        except PluginError as exc:
            if builtin:
                raise
            broken.append(Broken(dist, ep.name, exc))
            continue
        out.extend(decls)
    if not any(d.builtin for d in out):
        raise MissingCapability(f"no builtin technique is registered in the entry-point group {GROUP}: the "
                                "installed iblcheck metadata is older than its pyproject.toml",
                                hint="reinstall iblcheck (pip install -e .)")
    builtins = sorted((d for d in out if d.builtin), key=lambda d: (d.rank, EFFECT_KEYS.index(d.effect)))
    return Registry((*builtins, *(d for d in out if not d.builtin)), tuple(broken))


def _package_file(package: str, name: str) -> bool:
    """Whether `package` (importable) holds the file `name`."""
    try:
        return resources.files(package).joinpath(name).is_file()
    except (ImportError, TypeError, ValueError):
        return False


def check_declaration(d: Declaration, label: str, others: Sequence[Declaration]) -> None:
    """Refuse a declaration that is incomplete, has wrong types, clashes with another or has bad
    parameter defaults (PluginDeclarationError naming the plugin)."""
    def bad(what: str) -> PluginDeclarationError:
        return PluginDeclarationError(f"{label}: {what}")

    if not isinstance(d.rank, int):
        raise bad(f"rank must be an integer, got {d.rank!r}")
    for name, kind in (("effect", str), ("name", str), ("implementation", str), ("timing_key", str)):
        value = getattr(d, name)
        if not isinstance(value, kind) or not value:
            raise bad(f"{name} must be a non-empty string, got {value!r}")
    if d.effect not in EFFECT_KEYS:
        raise bad(f"effect = {d.effect!r}: must be one of {', '.join(EFFECT_KEYS)}")
    if not d.name.isidentifier() or d.name == NOTHING:
        raise bad(f"name = {d.name!r}: must be a lowercase identifier other than {NOTHING!r}")
    if ":" not in d.implementation:
        raise bad(f"implementation = {d.implementation!r}: must be \"module:Class\"")
    if not isinstance(d.simulates, (set, frozenset)) or not d.simulates:
        raise bad(f"simulates must be a non-empty frozenset of effects, got {d.simulates!r}")
    for key in ("reads", "extra_timing_keys", "fragment_glsl", "vertex_glsl", "ladder"):
        if not isinstance(getattr(d, key), tuple):
            raise bad(f"{key} must be a tuple, got {type(getattr(d, key)).__name__}")
    if not all(isinstance(k, str) and k for k in d.extra_timing_keys):
        raise bad("extra_timing_keys must hold non-empty strings")
    reserved = RESERVED_TIMING_KEYS & {d.timing_key, *d.extra_timing_keys}
    if reserved or any(k.endswith("_p90") for k in (d.timing_key, *d.extra_timing_keys)):
        raise bad(f"timing keys {sorted(reserved) or [d.timing_key, *d.extra_timing_keys]}: the frame's own keys "
                  f"({', '.join(sorted(RESERVED_TIMING_KEYS))}) and names ending in _p90 are not a technique's")
    if not isinstance(d.axes, Mapping) or not all(isinstance(v, tuple) and v for v in d.axes.values()):
        raise bad("axes must map scene keys to non-empty tuples of values")
    if not all(isinstance(p, dict) for p in d.ladder):
        raise bad("ladder must be a tuple of override dicts")
    if (d.fragment_glsl or d.vertex_glsl) and not d.package:
        raise bad("declares GLSL files but no package to find them in")
    missing = [f for f in (*d.fragment_glsl, *d.vertex_glsl) if not _package_file(d.package, f)]
    if missing:
        raise bad(f"declares GLSL files its package {d.package!r} does not hold: {', '.join(missing)}")
    for hook in ("validate", "validate_objects", "describe", "covers", "effective_settings"):
        if getattr(d, hook) is not None and not callable(getattr(d, hook)):
            raise bad(f"{hook} must be a function")
    if (d.table is None) != (d.parameters is None):
        raise bad("table and parameters go together: a table name and its dataclass")
    for cls, where in ((d.parameters, f"realtime.{d.table}"), (d.flat, "realtime")):
        if cls is None:
            continue
        if not (dataclasses.is_dataclass(cls) and isinstance(cls, type) and cls.__dataclass_params__.frozen):
            raise bad(f"the parameters of {where} must be a frozen dataclass")
        for f in dataclasses.fields(cls):
            check = f.metadata.get("check")
            if check is None or not callable(check[0]):
                raise bad(f"{where}.{f.name} has no check: declare it with param(default, check)")
            if f.default is dataclasses.MISSING or check[0](f.default) is None:
                raise bad(f"{where}.{f.name} = {f.default!r}: its default is outside its range ({check[1]})")
    for o in others:
        if (o.effect, o.name) == (d.effect, d.name):
            raise bad(f"{d.choice} is already registered by {o.distribution!r}")
        if d.table is not None and o.table == d.table and o.parameters is not d.parameters:
            raise bad(f"table realtime.{d.table} is already declared by {o.distribution!r} ({o.choice})")
        if d.flat is not None and o.flat is not None and o.flat is not d.flat:
            clash = set(parameter_checks(d.flat)) & set(parameter_checks(o.flat))
            if clash:
                raise bad(f"realtime.{sorted(clash)[0]} is already declared by {o.distribution!r} ({o.choice})")
    if d.table in RESERVED_TABLES or (d.flat is not None and set(parameter_checks(d.flat)) & RESERVED_KEYS):
        raise bad("its parameters clash with a key of the scene model's own [realtime] table")


#: [realtime] keys and tables of the engine itself (scenes/model/scene.py), which no technique may declare
RESERVED_KEYS = {"base_size", "face_size", "rotate_deg_per_frame", "timing_frames", "warmup_frames",
                 "parameterization", "reflection", *EFFECT_KEYS}
RESERVED_TABLES = {"sphere_map"}


# --------------------------------------------------------------------------- queries


def declarations() -> list[Declaration]:
    """Every registered technique, builtins first (see the module docstring)."""
    return list(registry().declarations)


def broken() -> list[Broken]:
    """The plugin entry points that could not be registered, with their errors."""
    return list(registry().broken)


def row_label(effect: str, techniques: Mapping[str, Any]) -> str:
    """How tables name the technique a row's `techniques` (describe's dict) chose for `effect`: its
    declaration's `row_label` hook, else its name (a technique no longer registered: its name too)."""
    name = techniques.get(effect)
    try:
        d = lookup(effect, name)
    except KeyError:
        return str(name)
    return d.call("row_label", techniques) if d.row_label is not None else str(name)


def lookup(effect: str, name: str) -> Declaration:
    """The declaration of `realtime.<effect> = "<name>"` (KeyError if there is none)."""
    for d in registry().declarations:
        if (d.effect, d.name) == (effect, name):
            return d
    raise KeyError((effect, name))


def choices(effect: str) -> tuple[str, ...]:
    """The values `realtime.<effect>` may take, in registry order ("none" first where allowed)."""
    names = tuple(d.name for d in registry().declarations if d.effect == effect)
    return (NOTHING, *names) if effect in OPTIONAL_EFFECTS else names


def refuse_broken_choice(effect: str, value: Any) -> None:
    """A choice no declaration has: if a broken plugin's entry point has that name, raise its error."""
    for b in registry().broken:
        if b.entry_point == value:
            raise b.error


def tables() -> dict[str, type]:
    """{table name: parameter dataclass} of every registered technique."""
    return {d.table: d.parameters for d in registry().declarations if d.table is not None}


def flat_parameters() -> dict[str, tuple[Declaration, Check, Any]]:
    """{flat [realtime] key: (its first declaration, check, default)}."""
    out: dict[str, tuple[Declaration, Check, Any]] = {}
    for d in registry().declarations:
        defaults = parameter_defaults(d.flat)
        for key, check in parameter_checks(d.flat).items():
            out.setdefault(key, (d, check, defaults[key]))
    return out


def chosen(rt) -> list[Declaration]:
    """The declarations of the scene's choices (every effect key, whether or not the scene has the effect)."""
    out = []
    for effect in EFFECT_KEYS:
        value = getattr(rt, effect)
        if value != NOTHING:
            out.append(lookup(effect, value))
    return out


def table_users(rt) -> dict[str, str | None]:
    """For each registered technique table, the `realtime.KEY = "VALUE"` choice that uses it (None: unused)."""
    users: dict[str, str | None] = {}
    picked = {(d.effect, d.name) for d in chosen(rt)}
    for d in registry().declarations:
        if d.table is None:
            continue
        users.setdefault(d.table, None)
        if users[d.table] is None and (d.effect, d.name) in picked:
            users[d.table] = d.choice
    return users


def table_hint(table: str) -> str:
    """The choices that read `table`, for the error naming an unused table."""
    hints = [d.table_hint for d in registry().declarations if d.table == table and d.table_hint]
    if hints:
        return hints[0]
    return " or ".join(d.choice for d in registry().declarations if d.table == table)


def validate(rt, given: dict, where: str) -> None:
    """Every builtin technique's rules against the scene's choices (Declaration.validate), and a plugin's
    where the scene chooses it: a plugin's rules cannot refuse, nor its bugs break, a scene without it."""
    for d in registry().declarations:
        if not d.builtin and getattr(rt, d.effect) != d.name:
            continue
        if d.validate is not None:
            d.call("validate", rt, given, where)


def shaded_materials(d: Declaration) -> frozenset[str]:
    """The material types technique `d` shades (Declaration.materials)."""
    return d.materials if d.materials is not None else PAPER_MATERIALS


def validate_objects(rt, objects, where: str) -> None:
    """Each chosen technique's rules against the objects, after the rule every technique shares: an
    object's lobe is shaded by a technique written for its material type (a Phong chain cannot shade a
    GGX lobe, a GGX chain not a Phong one)."""
    for d in chosen(rt):
        for i, obj in enumerate(objects):
            m = obj.material
            uses = {"diffuse": m.has_diffuse, "glossy": m.has_glossy}.get(d.effect, True)
            if uses and m.type not in shaded_materials(d):
                fit = [e.choice for e in registry().declarations if e.effect == d.effect
                       and m.type in shaded_materials(e)]
                raise SceneError(f"{where}: objects[{i}].material.type = {m.type!r} with {d.choice}: it shades "
                                 f"{', '.join(sorted(shaded_materials(d)))} materials only; "
                                 + (f"choose {' or '.join(fit)}" if fit else "no registered technique shades it"))
    for d in chosen(rt):
        if d.validate_objects is not None:
            d.call("validate_objects", rt, objects, where)


def combination_error(rt, key_a: str, key_b: str, why: str, where: str) -> SceneError:
    """The error for two [realtime] keys that do not go together, naming both with their values."""
    return SceneError(f"{where}: realtime.{key_a} = {getattr(rt, key_a)!r} with realtime.{key_b} = "
                      f"{getattr(rt, key_b)!r}: {why}")


def require_cube(rt, effect: str, where: str) -> None:
    """A technique that convolves the cube map refuses the 2D parameterizations."""
    if rt.parameterization != "cube":
        value = getattr(rt, effect)
        raise combination_error(rt, effect, "parameterization", f'realtime.{effect} = "{value}" reads the cube '
                                'map; set realtime.parameterization = "cube" or choose another technique', where)
