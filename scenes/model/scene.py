"""The scene model: TOML file -> validated, frozen dataclasses (docs/contract.md section 5).

Everything is checked on load. Each bad value raises `SceneError` with a message of the form

    <file>: <key> = <value>: <what is allowed>

`with_overrides({"realtime.lod_bias": 2})` returns a new, re-validated scene; string values are
parsed as TOML literals first, so `--set realtime.lod_bias=2` works from the CLI. Keys into the
object list take an index or `*` (all objects): `objects.0.material.exponent`, `objects.*.scale`.
"""

from __future__ import annotations

import copy
import math
import os
import re
import tomllib
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, is_dataclass
from functools import cached_property, lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from scenes.environment import environments, envmap
from scenes.geometry import meshes
from scenes.model import materials, technique_registry
from scenes.model.camera import Camera
from scenes.storage.errors import InputError, SceneError
from scenes.storage.files import input_problem, read_input, short_repr

BUILTIN_PREFIX = "builtin:"
MATERIAL_TYPES = materials.NAMES
EFFECTS = ("diffuse", "glossy", "fresnel", "occlusion", "interreflection")
#: a scene file larger than this is refused before it is parsed
MAX_SCENE_BYTES = 16 << 20
#: tables and arrays nest at most this deep (a scene needs 4: objects, an object, its material, kd)
MAX_DEPTH = 16
#: the most pixels an image may have (8192 x 8192): both renderers hold several float32 copies of it
MAX_PIXELS = 1 << 26
#: the most shadow-map texels a light array may ask for (count x shadow_map_size^2 32-bit depths: 1 GiB;
#: realtime.occlusion = "shadow_maps" refuses more)
MAX_SHADOW_TEXELS = 1 << 28


# --------------------------------------------------------------------------- dataclasses


@dataclass(frozen=True)
class Material:
    type: str = "diffuse"
    kd: tuple[float, float, float] = (0.8, 0.8, 0.8)
    ks: tuple[float, float, float] = (1.0, 1.0, 1.0)
    exponent: float = 100.0
    f0: float = 0.04
    two_sided: bool = False  # see scenes/model/materials.py: one-sided by default
    # type = "pbr" (glTF 2.0 metallic-roughness): linear RGB, and the two factors in [0, 1]
    base_color: tuple[float, float, float] = (0.8, 0.8, 0.8)
    metallic: float = 0.0
    roughness: float = 0.5

    @property
    def has_diffuse(self) -> bool:
        return materials.has_diffuse(self)

    @property
    def has_glossy(self) -> bool:
        return materials.has_glossy(self)


@dataclass(frozen=True)
class SceneObject:
    shape: str = "sphere"  # builtin name or an absolute path to a mesh file (meshes.MESH_FORMATS)
    translate: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotate_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale: float = 1.0
    resolution: int | None = None
    material: Material = field(default_factory=Material)
    normals: str = "auto"  # auto | file | smooth | flat (meshes.make_mesh)
    crease_deg: float | None = None  # with normals = "smooth": hard edges where faces meet at more than this

    @cached_property
    def mesh(self) -> meshes.Mesh:
        """The object's triangles in world space (the same arrays both renderers draw)."""
        if self.shape in meshes.BUILTIN_MESHES:
            base = meshes.shaded(meshes.builtin(self.shape, self.resolution), self.normals, self.crease_deg)
        else:
            base = meshes.load_file(self.shape, self.normals, self.crease_deg)
        return base.transformed(self.scale, self.rotate_deg, self.translate)


@dataclass(frozen=True)
class Environment:
    map: str = "builtin:uffizi"  # "builtin:NAME" or an absolute path
    rotation_deg: float = 0.0
    scale: float = 1.0
    params: tuple[tuple[str, float], ...] = ()
    sanitize: bool = False  # replace NaN / Inf / negative pixels by 0 (counted in a warning) instead of refusing

    @property
    def builtin_name(self) -> str | None:
        return self.map[len(BUILTIN_PREFIX):] if self.map.startswith(BUILTIN_PREFIX) else None

    def radiance(self, sanitize: bool | None = None) -> np.ndarray:
        """The map's (H, W, 3) float32 radiance times `scale` (rotation is applied at lookup).

        Read-only and cached per file state; `sanitize` defaults to `environment.sanitize`."""
        name = self.builtin_name
        sanitize = self.sanitize if sanitize is None else sanitize
        if name:
            arr = environments.builtin(name, dict(self.params))
        else:
            st = Path(self.map).stat()
            arr = _read_map(self.map, st.st_mtime_ns, st.st_size, sanitize)
        if self.scale != 1.0:
            with np.errstate(over="ignore"):
                arr = (arr * np.float32(self.scale)).astype(np.float32)
        envmap.check_peak(arr, self.map, self.scale)
        return arr


@lru_cache(maxsize=8)
def _read_map(path: str, mtime_ns: int, size: int, sanitize: bool) -> np.ndarray:
    arr = envmap.read(path, sanitize=sanitize)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class ToneMap:
    key: float = 0.18
    white: float = 4.0
    exposure: float = 0.0


@dataclass(frozen=True)
class SphereMap:
    """[realtime.sphere_map]: the view the sphere map is made for (realtime/engine/environment_maps.py)."""
    capture: str | tuple[float, float, float] = "camera"  # "camera" (remade for the render view) or a view direction


@dataclass(frozen=True)
class EngineCommand:
    """[realtime.command]: the external engine that renders the scene when `realtime.renderer = "command"`
    (engines/command.py): a builtin bridge by name, or a command template of one's own."""
    engine: str = ""  # "threejs" | "babylon" | "cycles" (engines/command.py BUILTIN_TEMPLATES), or "" with a template
    template: str = ""  # a command line with {placeholders} for the exported files and the output image
    timeout_s: float = 600.0


@dataclass(frozen=True)
class Realtime:
    """[realtime]: the engine's own keys as fields, the techniques' keys in `settings`.

    A technique's keys (the flat ones it reads, like `sh_order`, and its table, like `[realtime.lights]`)
    are declared by the technique (scenes/model/technique_registry.py) and read here by attribute all the
    same: `rt.sh_order`, `rt.lights.count`.

    Which technique keys a scene carries (and `Scene.to_dict()` returns, so its content id): every
    builtin technique's, with their defaults where the file does not set them, whether or not it is
    chosen; a plugin technique's only when the scene chooses it. So installing a plugin changes no
    builtin scene's content id.
    """
    base_size: int = 256
    face_size: int | str = 64
    rotate_deg_per_frame: float = 0.0
    timing_frames: int = 30
    warmup_frames: int = 5
    # the techniques (docs/architecture.md); the defaults are the paper's method
    diffuse: str = "sh"
    glossy: str = "box"
    occlusion: str = "none"
    interreflection: str = "none"
    parameterization: str = "cube"
    reflection: str = "per_pixel"  # or "per_vertex": the mirror direction interpolated from the vertices
    sphere_map: SphereMap = field(default_factory=SphereMap)
    #: "opengl" (iblcheck's own renderer and its techniques) or "command": an external engine, [realtime.command]
    renderer: str = "opengl"
    command: EngineCommand = field(default_factory=EngineCommand)
    #: (key, value) of the techniques' keys: flat values and table dataclasses, in registry order
    settings: tuple[tuple[str, Any], ...] = ()

    def __getattr__(self, name: str) -> Any:
        for key, value in self.__dict__.get("settings", ()):
            if key == name:
                return value
        raise AttributeError(f"[realtime] has no key {name!r} here: no chosen or builtin technique declares it")

    def to_dict(self) -> dict:
        """The engine's keys, then the techniques' keys (tables as dicts)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)
               if f.name not in ("sphere_map", "settings", "renderer", "command")}
        for key, value in self.settings:
            out[key] = asdict(value) if is_dataclass(value) else value
        out["sphere_map"] = asdict(self.sphere_map)
        out["renderer"] = self.renderer
        out["command"] = asdict(self.command)
        return out


@dataclass(frozen=True)
class Reference:
    spp: int = 1024
    seed: int = 0
    integrator: str = "auto"
    model: str = "paper"
    max_depth: int = 16
    #: "environment" (the map itself) or "light_array": the scene's [realtime.lights] array as N
    #: directional emitters, which splits the light array's error into discretisation and shadows (E8)
    lighting: str = "environment"


@dataclass(frozen=True)
class Gate:
    min_psnr: float | None = None
    min_ssim: float | None = None
    max_flip: float | None = None
    # an empty comparison (no lit pixel in the reference, none below white, too few covered pixels) is expected:
    # the gate passes it instead of failing it (experiments/runs/gate.py)
    allow_empty: bool = False


@dataclass(frozen=True)
class Scene:
    name: str
    environment: Environment
    camera: Camera
    objects: tuple[SceneObject, ...]
    tonemap: ToneMap
    realtime: Realtime
    reference: Reference
    gate: Gate
    path: str = ""  # where it was loaded from ("builtin:NAME" or a file path)
    source: dict = field(default_factory=dict, repr=False, compare=False)  # the raw TOML tree

    @cached_property
    def effects(self) -> frozenset[str]:
        """The effects this scene needs (docs/contract.md section 4), derived, never written by hand."""
        out = set()
        if any(o.material.has_diffuse for o in self.objects):
            out.add("diffuse")
        if any(o.material.has_glossy for o in self.objects):
            out.add("glossy")
        if any(materials.of(o.material).fresnel in ("schlick", "gltf") for o in self.objects):
            out.add("fresnel")
        if len(self.objects) > 1 or any(not o.mesh.convex for o in self.objects):
            out |= {"occlusion", "interreflection"}
        return frozenset(out)

    def with_overrides(self, overrides: dict[str, Any]) -> Scene:
        """A new scene with dotted keys replaced, re-validated. Paths are taken as given or
        relative to the working directory. A new `environment.map` drops the old map's `environment.params`
        (they are that map's: builtin:sky's sun is no parameter of builtin:ennis) unless the overrides give
        params of their own."""
        tree = copy.deepcopy(self.source)
        for key, value in overrides.items():
            if isinstance(value, str):
                value = parse_literal(value)
            if key in ("environment.map",) or key.endswith(".shape"):
                value = _cwd_path(value)
            if key == "environment.map" and isinstance(tree.get("environment"), dict):
                if value != tree["environment"].get("map") and not any(
                        k.startswith("environment.params") for k in overrides):
                    tree["environment"].pop("params", None)
            _set_dotted(tree, key.split("."), value, key, self.path)
        try:
            return from_dict(tree, self.path, base_dir=self._base_dir(), name_default=self.name)
        except UnknownKey as exc:
            key = _override_naming(exc.key, overrides)
            if key is None:
                raise
            named = "" if exc.key == key else f"{exc.key}: "
            raise SceneError(f"{self.path}: override {key}: {named}unknown key; allowed: {exc.allowed}") from None
        except BadValue as exc:
            # a value the overrides gave (the scene was valid before them): named as typed, so that nobody looks
            # for it in the file
            typed = _override_naming(exc.key, overrides)
            if typed is None:
                raise
            raise BadValue(self.path, f"override {typed}", exc.detail) from None

    def _base_dir(self) -> Path:
        return Path.cwd() if self.path.startswith(BUILTIN_PREFIX) or not self.path else Path(self.path).parent

    def to_dict(self) -> dict:
        """The full normalised configuration (every default filled in), JSON-serialisable."""
        d = asdict(self)
        d.pop("source", None)
        d["environment"]["params"] = dict(self.environment.params)
        d["realtime"] = self.realtime.to_dict()
        d["effects"] = sorted(self.effects)
        return d

    def content_dict(self) -> dict:
        """`to_dict()` as result rows hash it (their content ids): without the keys added to the scene format
        after those ids were first pinned (ADDED_KEYS) where this scene does not use them, so that a new
        material type or technique leaves every earlier row's id, and so its resumability, as it was."""
        d = self.to_dict()
        for obj, od in zip(self.objects, d["objects"], strict=True):
            used = materials.of(obj.material).all_fields
            for key in ADDED_KEYS["material"]:
                if key not in used:
                    od["material"].pop(key, None)
        users = table_users(self.realtime)
        for key in ADDED_KEYS["realtime"]:  # a table where nothing reads it; the renderer where it is the default
            used = self.realtime.renderer != "opengl" if key == "renderer" else users.get(key) is not None
            if not used:
                d["realtime"].pop(key, None)
        for table, keys in ADDED_TABLE_KEYS.items():  # a key added inside a table: absent while at its default
            for key, default in keys.items():
                if d["realtime"].get(table, {}).get(key, default) == default:
                    d["realtime"].get(table, {}).pop(key, None)
        return d


# --------------------------------------------------------------------------- schema

# each check: (value -> normalised value or None, what is allowed); the technique's checks are the
# registry's (number, power_of_two, one_of), which the scene's own keys use too
_num = technique_registry.number
_pow2 = technique_registry.power_of_two
_enum = technique_registry.one_of


def _vec3(lo: float = -1e6, hi: float = 1e6):
    text = f"a list of 3 numbers in [{lo:g}, {hi:g}]"

    def check(v):
        if not isinstance(v, (list, tuple)) or len(v) != 3:
            return None
        out = []
        for x in v:
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x) or not lo <= x <= hi:
                return None
            out.append(float(x))
        return tuple(out)

    return check, text


def _with_reason(check: tuple, reason: str) -> tuple:
    """A check whose error message also says why the range is what it is."""
    return check[0], f"{check[1]} ({reason})"


def _view_direction():
    text = 'one of "camera" or a view direction: a list of 3 finite numbers, not all zero'

    def check(v):
        if v == "camera":
            return v
        vec = _vec3()[0](v)
        if vec is None or not any(vec):
            return None
        return vec

    return check, text


def _bool():
    return (lambda v: v if isinstance(v, bool) else None), "true or false"


def _string():
    return (lambda v: v if isinstance(v, str) and v else None), "a non-empty string"


_SCENE_SCHEMA: dict[str, dict[str, tuple]] = {
    "environment": {
        "map": _string(),
        "rotation_deg": _num(-1e4, 1e4),
        "scale": _num(0, 1e9),
        "sanitize": _bool(),
    },
    "camera": {
        "origin": _vec3(),
        "target": _vec3(),
        "up": _vec3(),
        "fov_deg": _num(1e-3, 180, hi_open=True),  # below 1e-3 degrees float32 projections break down
        "width": _num(1, 16384, integer=True),
        "height": _num(1, 16384, integer=True),
    },
    "object": {
        "shape": _string(),
        "translate": _vec3(),
        "rotate_deg": _vec3(-1e4, 1e4),
        "scale": _num(0, 1e6, lo_open=True),
        "resolution": _num(2, 1024, integer=True),
        "normals": _enum(*meshes.NORMALS),
        "crease_deg": _num(0, 180),
    },
    "material": {
        "type": _enum(*MATERIAL_TYPES),
        "kd": _vec3(0.0, 1.0),
        "ks": _vec3(0.0, 1.0),
        "exponent": _num(0, 1e7),
        "f0": _num(0, 1),
        "two_sided": _bool(),
        "base_color": _vec3(0.0, 1.0),
        "metallic": _with_reason(_num(0, 1), "glTF 2.0's metallic factor: 0 dielectric, 1 metal, between a mix"),
        "roughness": _with_reason(_num(0, 1), "glTF 2.0's roughness factor, alpha = roughness^2: 0 a mirror, "
                                              "1 the roughest GGX lobe"),
    },
    "tonemap": {
        "key": _num(0, 100, lo_open=True),
        "white": _num(0, 1e6, lo_open=True),
        "exposure": _num(-50, 50),
    },
    "realtime": {
        "base_size": _pow2(1, 4096),
        "face_size": _pow2(1, 4096, allow_auto=True),
        "rotate_deg_per_frame": _num(-360, 360),
        "timing_frames": _num(1, 100000, integer=True),
        "warmup_frames": _num(0, 10000, integer=True),
        "parameterization": _enum("cube", "dual_paraboloid", "sphere_map"),
        "reflection": _enum("per_pixel", "per_vertex"),
        "renderer": _enum("opengl", "command"),
    },
    "realtime.sphere_map": {
        "capture": _view_direction(),
    },
    "realtime.command": {
        "engine": _enum("threejs", "babylon", "cycles"),
        "template": _string(),
        "timeout_s": _num(1, 86400),
    },
    "reference": {
        "spp": _num(1, 1 << 24, integer=True),
        "seed": _num(0, 2**31 - 1, integer=True),
        "integrator": _enum("auto", "direct", "path"),
        "model": _enum("paper", "physical"),
        "max_depth": _num(2, 1000, integer=True),
        "lighting": _enum("environment", "light_array"),
    },
    "gate": {
        "min_psnr": _num(-1e3, 1e3),
        "min_ssim": _num(-1, 1),
        "max_flip": _num(0, 1),
        "allow_empty": _bool(),
    },
}


#: keys added to the scene format after result rows' content ids were first pinned (Scene.content_dict):
#: they enter a row's id only where the scene uses them (a material field its type has, a technique
#: table its chosen technique reads). A key added to the format later is listed here too.
ADDED_KEYS = {
    "material": ("base_color", "metallic", "roughness"),
    "realtime": ("split_sum", "renderer", "command", "wavelet_prt"),
}
#: keys added to a technique's table after the ids were pinned, with their defaults: they enter a row's id only
#: where the scene sets them to something else
ADDED_TABLE_KEYS = {"vct": {"bounces": 1, "glossy_read": "deferred"}}


class _Schema(Mapping):
    """{section: {key: check}}: the scene model's own keys, and [realtime]'s technique keys as the registered
    techniques declare them (the choices of each effect key, their flat keys, their tables), gathered
    on first use (scenes/model/technique_registry.py)."""

    _built: tuple[object, dict[str, dict[str, tuple]]] | None = None  # (the registry it was built from, schema)

    @property
    def _full(self) -> dict[str, dict[str, tuple]]:
        registry = technique_registry.registry()
        if self._built is None or self._built[0] is not registry:
            self._built = (registry, self._build())
        return self._built[1]

    def _build(self) -> dict[str, dict[str, tuple]]:
        out = {k: dict(v) for k, v in _SCENE_SCHEMA.items()}
        rt = out["realtime"]
        for effect in technique_registry.EFFECT_KEYS:
            rt[effect] = _enum(*technique_registry.choices(effect))
        for key, (_, check, _) in technique_registry.flat_parameters().items():
            rt[key] = check
        for name, cls in technique_registry.tables().items():
            out[f"realtime.{name}"] = technique_registry.parameter_checks(cls)
        return out

    def __getitem__(self, key: str) -> dict[str, tuple]:
        return self._full[key]

    def __iter__(self):
        return iter(self._full)

    def __len__(self) -> int:
        return len(self._full)


SCHEMA: Mapping[str, dict[str, tuple]] = _Schema()
#: keys allowed per material type (the others do not apply and are refused)
MATERIAL_KEYS = {name: set(t.scene_keys) for name, t in materials.TYPES.items()}
TOP_KEYS = {"name", "environment", "camera", "objects", "tonemap", "realtime", "reference", "gate"}


# --------------------------------------------------------------------------- loading


def load(path_or_builtin: str | Path) -> Scene:
    """Load and validate a scene: a TOML file path or `builtin:NAME`."""
    text_path = str(path_or_builtin)
    if text_path.startswith(BUILTIN_PREFIX):
        name = text_path[len(BUILTIN_PREFIX):]
        res = resources.files("scenes").joinpath(f"data/scenes/{name}.toml")
        if not res.is_file():
            raise SceneError(f"{text_path}: unknown builtin scene; choose one of {', '.join(builtin_names())}")
        return _parse_text(res.read_text(), text_path, Path.cwd(), name)
    path = Path(text_path)
    return _parse_text(_read_scene_text(path), str(path), path.resolve().parent, path.stem)


def _read_scene_text(path: Path) -> str:
    """The text of a scene file: a readable regular file of UTF-8 text, not too large."""
    data = read_input(path, "scene file", MAX_SCENE_BYTES, SceneError)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start}); "
                         "TOML files are UTF-8") from None
    return text.removeprefix("\ufeff")  # a byte-order mark is no TOML statement


def builtin_names() -> list[str]:
    folder = resources.files("scenes").joinpath("data/scenes")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def _parse_text(text: str, where: str, base_dir: Path, stem: str) -> Scene:
    try:
        tree = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{where}: malformed TOML: {exc}") from None
    except RecursionError:
        raise SceneError(f"{where}: arrays or tables nested too deeply to read (a scene nests at most "
                         f"{MAX_DEPTH} levels)") from None
    _check_depth(tree, where)
    return from_dict(tree, where, base_dir, name_default=stem)


def _check_depth(tree: Any, where: str) -> None:
    """Refuse values nested deeper than MAX_DEPTH, naming the key where they start (no recursion)."""
    stack = [(tree, "", 0)]
    while stack:
        node, key, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise SceneError(f"{where}: {key or 'the file'}: arrays or tables nested more than {MAX_DEPTH} levels deep")
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        for k, v in items:
            if isinstance(v, (dict, list)):
                stack.append((v, f"{key}.{k}" if key and isinstance(k, str) else f"{key}[{k}]" if key else str(k),
                              depth + 1))


class BadValue(SceneError):
    """A value the scene format refuses for one key: `key` as the file names it (`camera.width`,
    `objects[0].resolution`), `detail` what follows `KEY = ` (the value and why). An error about two keys together
    stays a plain SceneError: either key may be the file's."""

    def __init__(self, where: str, key: str, detail: str) -> None:
        self.where, self.key, self.detail = where, key, detail
        super().__init__(f"{where}: {key} = {detail}")

    def __reduce__(self):  # pickled whole (a Dask worker's error reaches the driver)
        return BadValue, (self.where, self.key, self.detail)


class UnknownKey(SceneError):
    """A key the scene format does not have; `key` as the file names it (`camera.fovv`, `objects[0].shapee`)."""

    def __init__(self, where: str, key: str, allowed) -> None:
        self.where, self.key, self.allowed_keys = where, key, tuple(sorted(allowed))
        self.allowed = ", ".join(self.allowed_keys)
        super().__init__(f"{where}: {key}: unknown key; allowed: {self.allowed}")

    def __reduce__(self):  # pickled whole (a Dask worker's error reaches the driver)
        return UnknownKey, (self.where, self.key, self.allowed_keys)


def from_dict(tree: dict, where: str, base_dir: Path, name_default: str = "scene") -> Scene:
    """Validate a raw TOML tree. Relative paths resolve against `base_dir`."""

    def fail(key: str, value: Any, allowed: str) -> SceneError:
        return BadValue(where, key, f"{short_repr(value)}: must be {allowed}")

    if not isinstance(tree, dict):
        raise SceneError(f"{where}: the scene must be a TOML table")
    for key in tree:
        if key not in TOP_KEYS:
            raise UnknownKey(where, key, TOP_KEYS)

    def section(name: str, table: Any, schema_name: str | None = None, prefix: str | None = None,
                allowed_keys: set | None = None) -> dict:
        schema = SCHEMA[schema_name or name]
        prefix = prefix or name
        if table is None:
            return {}
        if not isinstance(table, dict):
            raise SceneError(f"{where}: {prefix} must be a table, got {short_repr(table)}")
        out = {}
        keys = allowed_keys if allowed_keys is not None else set(schema)
        for key, value in table.items():
            if key not in keys:
                raise UnknownKey(where, f"{prefix}.{key}", keys)
            if key not in schema:
                continue
            check, text = schema[key]
            checked = check(value)
            if checked is None:
                raise fail(f"{prefix}.{key}", value, text)
            out[key] = checked
        return out

    name = tree.get("name", name_default)
    if not isinstance(name, str) or not name:
        raise fail("name", name, "a non-empty string")

    # environment
    env_raw = tree.get("environment", {})
    params = env_raw.get("params", {}) if isinstance(env_raw, dict) else {}
    env_raw = {k: v for k, v in env_raw.items() if k != "params"} if isinstance(env_raw, dict) else env_raw
    env = section("environment", env_raw)
    env_map = env.get("map", Environment.map)
    if env_map.startswith(BUILTIN_PREFIX):
        try:
            resolved = environments.resolve_params(env_map[len(BUILTIN_PREFIX):], params)
        except SceneError as exc:
            raise BadValue(where, "environment.map", f"{short_repr(env_map)}: {exc}") from None
        env["params"] = tuple(sorted(resolved.items()))
    else:
        if params:
            raise SceneError(f"{where}: environment.params: only builtin environments take parameters")
        p = Path(env_map)
        p = p if p.is_absolute() else (base_dir / p)
        if p.suffix.lower() not in (".exr", ".hdr", ".pfm"):
            raise fail("environment.map", env_map, "a builtin name or an .exr, .hdr or .pfm file")
        problem = input_problem(p)
        if problem:
            raise BadValue(where, "environment.map", f"{short_repr(env_map)}: {problem} ({p})")
        env["map"] = str(p)
    environment = Environment(**env)

    # camera
    cam = Camera(**section("camera", tree.get("camera", {})))
    if cam.width * cam.height > MAX_PIXELS:
        raise SceneError(f"{where}: camera.width x camera.height = {cam.width} x {cam.height} = "
                         f"{cam.width * cam.height} pixels: must be at most {MAX_PIXELS} (8192 x 8192)")
    view = np.subtract(cam.target, cam.origin)
    if np.linalg.norm(view) < 1e-9:
        raise BadValue(where, "camera.target", f"{list(cam.target)}: must differ from camera.origin")
    if np.linalg.norm(np.cross(view / np.linalg.norm(view), cam.up)) < 1e-6:
        raise BadValue(where, "camera.up", f"{list(cam.up)}: must not be zero or parallel to the view direction")

    # objects
    # no default object: a scene without [[objects]] would render something the file never names
    if "objects" not in tree:
        raise SceneError(f"{where}: objects: missing: a scene needs at least one [[objects]] table (e.g. "
                         '[[objects]] shape = "sphere")')
    objs_raw = tree["objects"]
    if not isinstance(objs_raw, list) or not objs_raw:
        raise fail("objects", objs_raw, "a non-empty array of tables ([[objects]])")
    objects = []
    for i, raw in enumerate(objs_raw):
        prefix = f"objects[{i}]"
        if not isinstance(raw, dict):
            raise SceneError(f"{where}: {prefix} must be a table")
        mat_raw = raw.get("material", {})
        rest = {k: v for k, v in raw.items() if k != "material"}
        obj = section("object", rest, prefix=prefix)
        mat_type = mat_raw.get("type", "diffuse") if isinstance(mat_raw, dict) else None
        if mat_type not in MATERIAL_TYPES:
            raise fail(f"{prefix}.material.type", mat_type, _enum(*MATERIAL_TYPES)[1])
        mat = section("material", mat_raw, prefix=f"{prefix}.material", allowed_keys=MATERIAL_KEYS[mat_type])
        defaults = dict(materials.TYPES[mat_type].defaults)
        obj["material"] = Material(**{**defaults, **mat})
        shape = obj.get("shape", "sphere")
        if shape in meshes.PACKAGED_MESHES and "resolution" in obj:
            raise SceneError(f"{where}: {prefix}.resolution = {obj['resolution']} with {prefix}.shape = {shape!r}: "
                             f"the {shape} is a packaged model with a fixed tessellation; resolution applies to "
                             f"{', '.join(sorted(set(meshes.BUILTIN_MESHES) - meshes.PACKAGED_MESHES))}")
        if shape in meshes.BUILTIN_MESHES and meshes.builtin_triangles(shape, obj.get("resolution")) > \
                meshes.MAX_TRIANGLES:
            raise BadValue(where, f"{prefix}.resolution", f"{obj.get('resolution')}: a {shape} of "
                           f"{meshes.builtin_triangles(shape, obj.get('resolution'))} triangles; must give at most "
                           f"{meshes.MAX_TRIANGLES}")
        if shape not in meshes.BUILTIN_MESHES:
            p = Path(shape)
            p = p if p.is_absolute() else base_dir / p
            if p.suffix.lower() not in meshes.MESH_FORMATS:
                raise fail(f"{prefix}.shape", shape, f"one of {', '.join(meshes.BUILTIN_MESHES)} or a mesh file "
                           f"({', '.join(meshes.MESH_FORMATS)})")
            problem = input_problem(p)
            if problem:
                raise BadValue(where, f"{prefix}.shape", f"{short_repr(shape)}: {problem} ({p})")
            obj["shape"] = str(p)
        if "crease_deg" in obj and obj.get("normals", "auto") != "smooth":
            raise SceneError(f"{where}: {prefix}.crease_deg = {obj['crease_deg']} with {prefix}.normals = "
                             f"{obj.get('normals', 'auto')!r}: a crease angle splits smooth normals; set "
                             f"{prefix}.normals = \"smooth\" or remove {prefix}.crease_deg")
        objects.append(SceneObject(**obj))

    realtime = _realtime(tree.get("realtime", {}), where, section)
    reference = Reference(**section("reference", tree.get("reference", {})))
    technique_registry.validate_objects(realtime, objects, where)
    if reference.lighting == "light_array" and "lights" not in (realtime.diffuse, realtime.glossy):
        raise SceneError(f"{where}: reference.lighting = 'light_array' with realtime.diffuse = {realtime.diffuse!r}: "
                         'the reference renders the real-time light array; set realtime.diffuse or realtime.glossy '
                         '= "lights"')

    scene = Scene(
        name=name,
        environment=environment,
        camera=cam,
        objects=tuple(objects),
        tonemap=ToneMap(**section("tonemap", tree.get("tonemap", {}))),
        realtime=realtime,
        reference=reference,
        gate=Gate(**section("gate", tree.get("gate", {}))),
        path=where,
        source=copy.deepcopy(tree),
    )
    try:  # load geometry now so a bad mesh file is reported at load time, naming the scene
        for obj in scene.objects:
            obj.mesh  # noqa: B018
    except InputError as exc:
        raise SceneError(f"{where}: {exc}") from None
    return scene


# --------------------------------------------------------------------------- techniques

#: the [realtime] tables of the engine itself (the techniques' tables are declared by the techniques)
ENGINE_TABLES = {"sphere_map": SphereMap, "command": EngineCommand}
#: technique choices that realtime/ does not have yet: refused at load ("not implemented yet"), never
#: ignored (tests/realtime/test_techniques.py checks that every other choice has a module).
NOT_IMPLEMENTED: frozenset[tuple[str, str]] = frozenset()


def table_users(rt: Realtime) -> dict[str, str | None]:
    """For each [realtime] table, the `realtime.KEY = "VALUE"` choice that uses it (None: unused)."""
    users = technique_registry.table_users(rt)
    users["sphere_map"] = 'realtime.parameterization = "sphere_map"' if rt.parameterization == "sphere_map" else None
    users["command"] = 'realtime.renderer = "command"' if rt.renderer == "command" else None
    return users


def _table_hint(name: str) -> str:
    if name == "command":
        return 'realtime.renderer = "command"'
    if name in ENGINE_TABLES:
        return 'realtime.parameterization = "sphere_map"'
    return technique_registry.table_hint(name)


def _realtime(raw: Any, where: str, section) -> Realtime:
    """[realtime]: its values (the techniques' as they declare them), then the use of every table and
    technique key given (pbrt's ReportUnused), then each technique's rules against the other choices."""
    if not isinstance(raw, dict):
        raise SceneError(f"{where}: realtime must be a table, got {short_repr(raw)}")
    technique_tables = technique_registry.tables()
    flat = {k: v for k, v in raw.items() if k not in technique_tables and k not in ENGINE_TABLES}
    for effect in technique_registry.EFFECT_KEYS:  # a choice of a plugin that failed to load: its own error
        if effect in flat and flat[effect] not in technique_registry.choices(effect):
            technique_registry.refuse_broken_choice(effect, flat[effect])
    values = section("realtime", flat)
    engine_keys = {f.name for f in fields(Realtime)}
    engine = {k: v for k, v in values.items() if k in engine_keys}
    if "sphere_map" in raw:
        engine["sphere_map"] = SphereMap(**section("realtime.sphere_map", raw["sphere_map"]))
    if "command" in raw:
        engine["command"] = EngineCommand(**section("realtime.command", raw["command"]))
        _check_command(engine["command"], where)
    elif engine.get("renderer") == "command":
        raise SceneError(f"{where}: realtime.renderer = 'command': add a [realtime.command] table naming the engine "
                         "(engine = \"threejs\", \"babylon\" or \"cycles\") or a command (template = \"...\")")
    choice = Realtime(**engine)
    picked = {(e, getattr(choice, e)) for e in technique_registry.EFFECT_KEYS}
    settings: dict[str, Any] = {}
    given_tables = {}
    for d in technique_registry.declarations():
        if not d.builtin and (d.effect, d.name) not in picked:
            continue  # a plugin's keys only where it is chosen (see Realtime)
        for key, default in technique_registry.parameter_defaults(d.flat).items():
            settings.setdefault(key, values.get(key, default))
        if d.table is not None and d.table not in settings:
            given_tables[d.table] = raw.get(d.table, {})
            settings[d.table] = d.parameters(**section(f"realtime.{d.table}", given_tables[d.table]))
    rt = Realtime(**engine, settings=tuple(settings.items()))
    fs = rt.face_size
    if fs != "auto" and fs > rt.base_size:
        raise SceneError(f"{where}: realtime.face_size = {fs!r}: must be at most realtime.base_size = {rt.base_size}")
    users = table_users(rt)
    for name in raw:  # pbrt's ReportUnused: a table or key nobody reads is a mistake, not a no-op
        if name in users and users[name] is None:
            raise SceneError(f"{where}: realtime.{name}: this table is not used by the chosen techniques; "
                             f"it applies to {_table_hint(name)}")
        if name in values and name not in engine_keys and name not in settings:
            owner = technique_registry.flat_parameters()[name][0]
            raise SceneError(f"{where}: realtime.{name}: this key is not read by the chosen techniques; it "
                             f"applies to {owner.choice}")
    technique_registry.validate(rt, {**flat, **given_tables}, where)
    for key in ("diffuse", "glossy", "occlusion", "interreflection", "parameterization"):
        if (key, getattr(rt, key)) in NOT_IMPLEMENTED:
            raise BadValue(where, f"realtime.{key}", f"{getattr(rt, key)!r}: not implemented yet")
    return rt


def _check_command(command: EngineCommand, where: str) -> None:
    """[realtime.command] names exactly one engine: a builtin bridge or a template of one's own."""
    if bool(command.engine) == bool(command.template.strip()):
        given = "both" if command.engine else "neither"
        raise SceneError(f"{where}: realtime.command: {given} of engine and template given; name a builtin engine "
                         "(engine = \"threejs\", \"babylon\" or \"cycles\") or a command (template = \"...\"), one "
                         "of the two")


# --------------------------------------------------------------------------- overrides


def parse_literal(text: str) -> Any:
    """A CLI value as a TOML literal (2 -> int, 2.5 -> float, [1,2,3] -> list, true -> bool);
    anything that is not a literal is kept as a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except (tomllib.TOMLDecodeError, RecursionError):
        return text


def _cwd_path(value: Any) -> Any:
    if isinstance(value, str) and not value.startswith(BUILTIN_PREFIX) and value not in meshes.BUILTIN_MESHES:
        try:
            return os.path.abspath(value)  # never Path.resolve(): it raises on a symbolic link loop
        except ValueError:  # a NUL character: refused with the key when the scene is validated
            return value
    return value


def _override_naming(named_key: str, overrides: dict[str, Any]) -> str | None:
    """The override an unknown key is about (a loaded scene's own file holds none): the error names the key as
    the file would (`objects[0].shapee`, or its first unknown part, `camer`), the override as typed
    (`objects.0.shapee`, `objects.*.shapee`, `camer.fov_deg`)."""
    named = re.sub(r"\[(\d+)\]", r".\1", named_key).split(".")
    for key in overrides:
        parts = key.split(".")
        if len(parts) >= len(named) and all(p == n or (p == "*" and n.isdigit())
                                            for p, n in zip(parts, named, strict=False)):
            return key
    return None


def _set_dotted(tree: dict, parts: list[str], value: Any, key: str, where: str) -> None:
    node: Any = tree
    for i, part in enumerate(parts[:-1]):
        if part == "objects":
            objs = node.setdefault("objects", [{}])
            if i + 1 >= len(parts) - 1:
                raise SceneError(f"{where}: override {key}: say which object (objects.0.KEY or objects.*.KEY)")
            sel = parts[i + 1]
            targets = objs if sel == "*" else None
            if targets is None:
                if not sel.isdigit() or int(sel) >= len(objs):
                    raise SceneError(f"{where}: override {key}: no object {short_repr(sel)} "
                                     f"(the scene has {len(objs)})")
                targets = [objs[int(sel)]]
            for t in targets:
                _set_dotted(t, parts[i + 2:], value, key, where)
            return
        nxt = node.get(part)
        if nxt is None:
            nxt = node[part] = {}
        if not isinstance(nxt, dict):
            raise SceneError(f"{where}: override {key}: {part} is not a table")
        node = nxt
    node[parts[-1]] = value
