"""The scene model: TOML file -> validated, frozen dataclasses (design.md section 5).

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
import tomllib
from dataclasses import asdict, dataclass, field
from functools import cached_property, lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from scenes.environment import environments
from scenes.geometry import meshes
from scenes.model import materials
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


# --------------------------------------------------------------------------- dataclasses


@dataclass(frozen=True)
class Material:
    type: str = "diffuse"
    kd: tuple[float, float, float] = (0.8, 0.8, 0.8)
    ks: tuple[float, float, float] = (1.0, 1.0, 1.0)
    exponent: float = 100.0
    f0: float = 0.04
    two_sided: bool = False  # see scenes/model/materials.py: one-sided by default

    @property
    def has_diffuse(self) -> bool:
        return materials.of(self).diffuse_lobe and max(self.kd) > 0

    @property
    def has_glossy(self) -> bool:
        return materials.of(self).glossy_lobe and max(self.ks) > 0


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
        from scenes.environment import envmap

        envmap.check_peak(arr, self.map, self.scale)
        return arr


@lru_cache(maxsize=8)
def _read_map(path: str, mtime_ns: int, size: int, sanitize: bool) -> np.ndarray:
    from scenes.environment import envmap

    arr = envmap.read(path, sanitize=sanitize)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class ToneMap:
    key: float = 0.18
    white: float = 4.0
    exposure: float = 0.0


@dataclass(frozen=True)
class Prefiltered:
    """[realtime.prefiltered]: the Phong-lobe prefiltered chain (realtime/techniques/prefiltered/prefilter.py)."""
    samples: int = 64  # meets the 50 ms per-frame budget here (E7 sweeps 16 ... 1024)
    bias: float = 0.0  # filtered importance sampling: levels added to 0.5 log2(Omega_s / Omega_p)


@dataclass(frozen=True)
class IrradianceMap:
    """[realtime.irradiance_map]: the exact cosine convolution into a cube map
    (realtime/techniques/irradiance_map/irradiance_convolution.py)."""
    size: int = 32  # face size of the irradiance cube map
    source_size: int = 32  # face size of the mip level that is convolved


@dataclass(frozen=True)
class Lights:
    """[realtime.lights]: the light array (scenes/environment/light_array.py, realtime/techniques/lights/lights.py)."""
    count: int = 42  # geodesic: a subdivided polyhedron's vertex count; median_cut: a power of two
    placement: str = "geodesic"
    shadow_map_size: int = 512  # one depth map per light (realtime.occlusion = "shadow_maps")


@dataclass(frozen=True)
class Prt:
    """[realtime.prt]: precomputed radiance transfer (realtime/techniques/prt/prt_transfer.py,
    realtime/techniques/prt/prt.py)."""
    order: int = 2  # SH order of the transfer (2: 9 coefficients ... 4: 25)
    rays: int = 256  # visibility rays per vertex (realtime.occlusion or interreflection = "prt")
    bounces: int = 0  # interreflected bounces (>= 1 with realtime.interreflection = "prt")


@dataclass(frozen=True)
class Vct:
    """[realtime.vct]: voxel cone tracing (realtime/techniques/vct/vct.py, realtime/techniques/vct/vct_math.py)."""
    resolution: int = 64
    cascades: int = 3
    diffuse_cones: int = 6
    step: float = 0.5


@dataclass(frozen=True)
class SphereMap:
    """[realtime.sphere_map]: the view the sphere map is made for (realtime/engine/environment_maps.py)."""
    capture: str | tuple[float, float, float] = "camera"  # "camera" (remade for the render view) or a view direction


@dataclass(frozen=True)
class Realtime:
    base_size: int = 256
    face_size: int | str = 64
    lod_bias: float = 0.0
    lod_mapping: str = "paper"
    sh_window: str = "none"
    rotate_deg_per_frame: float = 0.0
    timing_frames: int = 30
    warmup_frames: int = 5
    # the techniques (design.md section 9); the defaults are the paper's method
    diffuse: str = "sh"
    sh_order: int = 2
    glossy: str = "box"
    occlusion: str = "none"
    interreflection: str = "none"
    parameterization: str = "cube"
    reflection: str = "per_pixel"  # or "per_vertex": the mirror direction interpolated from the vertices
    prefiltered: Prefiltered = field(default_factory=Prefiltered)
    irradiance_map: IrradianceMap = field(default_factory=IrradianceMap)
    lights: Lights = field(default_factory=Lights)
    prt: Prt = field(default_factory=Prt)
    vct: Vct = field(default_factory=Vct)
    sphere_map: SphereMap = field(default_factory=SphereMap)


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
        """The effects this scene needs (design.md section 4), derived, never written by hand."""
        out = set()
        if any(o.material.has_diffuse for o in self.objects):
            out.add("diffuse")
        if any(o.material.has_glossy for o in self.objects):
            out.add("glossy")
        if any(materials.of(o.material).fresnel == "schlick" for o in self.objects):
            out.add("fresnel")
        if len(self.objects) > 1 or any(not o.mesh.convex for o in self.objects):
            out |= {"occlusion", "interreflection"}
        return frozenset(out)

    def with_overrides(self, overrides: dict[str, Any]) -> Scene:
        """A new scene with dotted keys replaced, re-validated. Paths are taken as given or
        relative to the working directory."""
        tree = copy.deepcopy(self.source)
        for key, value in overrides.items():
            if isinstance(value, str):
                value = parse_literal(value)
            if key in ("environment.map",) or key.endswith(".shape"):
                value = _cwd_path(value)
            _set_dotted(tree, key.split("."), value, key, self.path)
        return from_dict(tree, self.path, base_dir=self._base_dir(), name_default=self.name)

    def _base_dir(self) -> Path:
        return Path.cwd() if self.path.startswith(BUILTIN_PREFIX) or not self.path else Path(self.path).parent

    def to_dict(self) -> dict:
        """The full normalised configuration (every default filled in), JSON-serialisable."""
        d = asdict(self)
        d.pop("source", None)
        d["environment"]["params"] = dict(self.environment.params)
        d["effects"] = sorted(self.effects)
        return d


# --------------------------------------------------------------------------- schema

Check = tuple[str, Any]  # (kind, argument)


def _num(lo: float, hi: float, lo_open: bool = False, hi_open: bool = False, integer: bool = False):
    lb = "(" if lo_open else "["
    rb = ")" if hi_open else "]"
    text = f"{'an integer' if integer else 'a number'} in {lb}{lo:g}, {hi:g}{rb}"

    def check(v):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or (integer and not isinstance(v, int)):
            return None
        if not math.isfinite(v):
            return None
        if (v < lo or v > hi) or (lo_open and v == lo) or (hi_open and v == hi):
            return None
        return int(v) if integer else float(v)

    return check, text


def _pow2(lo: int, hi: int, allow_auto: bool = False):
    text = f"a power of two in [{lo}, {hi}]" + (' or "auto"' if allow_auto else "")

    def check(v):
        if allow_auto and v == "auto":
            return v
        if isinstance(v, bool) or not isinstance(v, int) or v < lo or v > hi or v & (v - 1):
            return None
        return v

    return check, text


def _enum(*choices):
    def check(v):
        return v if v in choices else None

    return check, "one of " + ", ".join(f'"{c}"' for c in choices)


def _int_choice(*choices: int):
    def check(v):
        return v if isinstance(v, int) and not isinstance(v, bool) and v in choices else None

    return check, "one of " + ", ".join(str(c) for c in choices)


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


SCHEMA: dict[str, dict[str, tuple]] = {
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
    },
    "tonemap": {
        "key": _num(0, 100, lo_open=True),
        "white": _num(0, 1e6, lo_open=True),
        "exposure": _num(-50, 50),
    },
    "realtime": {
        "base_size": _pow2(1, 4096),
        "face_size": _pow2(1, 4096, allow_auto=True),
        "lod_bias": _num(-32, 32),
        "lod_mapping": _enum("paper", "mcguire"),
        "sh_window": _enum("none", "hanning", "lanczos", "auto"),
        "rotate_deg_per_frame": _num(-360, 360),
        "timing_frames": _num(1, 100000, integer=True),
        "warmup_frames": _num(0, 10000, integer=True),
        "diffuse": _enum("sh", "irradiance_map", "lights", "prt"),
        "sh_order": _num(2, 4, integer=True),
        "glossy": _enum("box", "prefiltered", "lights"),
        "occlusion": _enum("none", "shadow_maps", "prt", "vct"),
        "interreflection": _enum("none", "prt", "vct"),
        "parameterization": _enum("cube", "dual_paraboloid", "sphere_map"),
        "reflection": _enum("per_pixel", "per_vertex"),
    },
    "realtime.prefiltered": {
        "samples": _num(1, 65536, integer=True),
        "bias": _num(-16, 16),
    },
    "realtime.irradiance_map": {
        "size": _pow2(1, 256),
        "source_size": _pow2(1, 256),
    },
    "realtime.sphere_map": {
        "capture": _view_direction(),
    },
    "realtime.lights": {
        "count": _num(1, 65536, integer=True),
        "placement": _enum("geodesic", "median_cut"),
        "shadow_map_size": _pow2(16, 8192),
    },
    "realtime.prt": {
        "order": _num(2, 4, integer=True),
        "rays": _num(1, 1 << 16, integer=True),
        "bounces": _num(0, 16, integer=True),
    },
    "realtime.vct": {
        "resolution": _pow2(8, 256),
        "cascades": _num(1, 4, integer=True),
        "diffuse_cones": _int_choice(4, 6, 9),
        "step": _num(0, 4, lo_open=True),
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
    },
}
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


def from_dict(tree: dict, where: str, base_dir: Path, name_default: str = "scene") -> Scene:
    """Validate a raw TOML tree. Relative paths resolve against `base_dir`."""

    def fail(key: str, value: Any, allowed: str) -> SceneError:
        return SceneError(f"{where}: {key} = {short_repr(value)}: must be {allowed}")

    if not isinstance(tree, dict):
        raise SceneError(f"{where}: the scene must be a TOML table")
    for key in tree:
        if key not in TOP_KEYS:
            raise SceneError(f"{where}: {key}: unknown key; allowed: {', '.join(sorted(TOP_KEYS))}")

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
                raise SceneError(f"{where}: {prefix}.{key}: unknown key; allowed: {', '.join(sorted(keys))}")
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
            raise SceneError(f"{where}: environment.map = {short_repr(env_map)}: {exc}") from None
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
            raise SceneError(f"{where}: environment.map = {short_repr(env_map)}: {problem} ({p})")
        env["map"] = str(p)
    environment = Environment(**env)

    # camera
    cam = Camera(**section("camera", tree.get("camera", {})))
    if cam.width * cam.height > MAX_PIXELS:
        raise SceneError(f"{where}: camera.width x camera.height = {cam.width} x {cam.height} = "
                         f"{cam.width * cam.height} pixels: must be at most {MAX_PIXELS} (8192 x 8192)")
    view = np.subtract(cam.target, cam.origin)
    if np.linalg.norm(view) < 1e-9:
        raise SceneError(f"{where}: camera.target = {list(cam.target)}: must differ from camera.origin")
    if np.linalg.norm(np.cross(view / np.linalg.norm(view), cam.up)) < 1e-6:
        raise SceneError(f"{where}: camera.up = {list(cam.up)}: must not be zero or parallel to the view direction")

    # objects
    objs_raw = tree.get("objects", [{}])
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
            raise SceneError(f"{where}: {prefix}.resolution = {obj.get('resolution')}: a {shape} of "
                             f"{meshes.builtin_triangles(shape, obj.get('resolution'))} triangles; must give at "
                             f"most {meshes.MAX_TRIANGLES}")
        if shape not in meshes.BUILTIN_MESHES:
            p = Path(shape)
            p = p if p.is_absolute() else base_dir / p
            if p.suffix.lower() not in meshes.MESH_FORMATS:
                raise fail(f"{prefix}.shape", shape, f"one of {', '.join(meshes.BUILTIN_MESHES)} or a mesh file "
                           f"({', '.join(meshes.MESH_FORMATS)})")
            problem = input_problem(p)
            if problem:
                raise SceneError(f"{where}: {prefix}.shape = {short_repr(shape)}: {problem} ({p})")
            obj["shape"] = str(p)
        if "crease_deg" in obj and obj.get("normals", "auto") != "smooth":
            raise SceneError(f"{where}: {prefix}.crease_deg = {obj['crease_deg']} with {prefix}.normals = "
                             f"{obj.get('normals', 'auto')!r}: a crease angle splits smooth normals; set "
                             f"{prefix}.normals = \"smooth\" or remove {prefix}.crease_deg")
        objects.append(SceneObject(**obj))

    realtime = _realtime(tree.get("realtime", {}), where, section)
    reference = Reference(**section("reference", tree.get("reference", {})))
    two_sided = [i for i, o in enumerate(objects) if o.material.two_sided]
    if realtime.diffuse == "prt" and two_sided:
        i = two_sided[0]
        raise SceneError(f"{where}: realtime.diffuse = 'prt' with objects[{i}].material.two_sided = true: precomputed "
                         "transfer is computed for the front side only (its back would be shaded with the front's "
                         "transfer); use one-sided materials or another diffuse technique")
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

#: the per-technique tables of [realtime] and their dataclasses
TECHNIQUE_TABLES = {"prefiltered": Prefiltered, "irradiance_map": IrradianceMap, "lights": Lights, "prt": Prt,
                    "vct": Vct, "sphere_map": SphereMap}
#: technique choices that realtime/ does not have yet: refused at load ("not implemented yet"), never
#: ignored. An issue that adds a technique removes its entry here (tests/realtime/test_techniques.py
#: checks that every other choice has a module).
NOT_IMPLEMENTED: frozenset[tuple[str, str]] = frozenset()
#: the most shadow-map texels a light array may ask for (count x shadow_map_size^2 32-bit depths: 1 GiB)
MAX_SHADOW_TEXELS = 1 << 28


def table_users(rt: Realtime) -> dict[str, str | None]:
    """For each technique table, the `realtime.KEY = "VALUE"` choice that uses it (None: unused)."""
    def first(*pairs: tuple[str, str]) -> str | None:
        return next((f'realtime.{k} = "{v}"' for k, v in pairs if getattr(rt, k) == v), None)

    return {"prefiltered": first(("glossy", "prefiltered")),
            "irradiance_map": first(("diffuse", "irradiance_map")),
            "lights": first(("diffuse", "lights"), ("glossy", "lights")),
            "prt": first(("diffuse", "prt"), ("occlusion", "prt"), ("interreflection", "prt")),
            "vct": first(("occlusion", "vct"), ("interreflection", "vct")),
            "sphere_map": first(("parameterization", "sphere_map"))}


def _realtime(raw: Any, where: str, section) -> Realtime:
    """[realtime] and its technique tables: values, then the tables' use, then combinations."""
    if not isinstance(raw, dict):
        raise SceneError(f"{where}: realtime must be a table, got {short_repr(raw)}")
    flat = {k: v for k, v in raw.items() if k not in TECHNIQUE_TABLES}
    tables = {}
    for name, cls in TECHNIQUE_TABLES.items():
        if name in raw:
            tables[name] = cls(**section(f"realtime.{name}", raw[name]))
    rt = Realtime(**section("realtime", flat), **tables)
    fs = rt.face_size
    if fs != "auto" and fs > rt.base_size:
        raise SceneError(f"{where}: realtime.face_size = {fs!r}: must be at most realtime.base_size = {rt.base_size}")
    users = table_users(rt)
    for name in tables:  # pbrt's ReportUnused: a table nobody reads is a mistake, not a no-op
        if users[name] is None:
            raise SceneError(f"{where}: realtime.{name}: this table is not used by the chosen techniques; "
                             f"it applies to {_table_hint(name)}")
    _check_combinations(rt, flat, where)
    _check_technique_tables(rt, raw, where)
    for key in ("diffuse", "glossy", "occlusion", "interreflection", "parameterization"):
        if (key, getattr(rt, key)) in NOT_IMPLEMENTED:
            raise SceneError(f"{where}: realtime.{key} = {getattr(rt, key)!r}: not implemented yet")
    m = rt.irradiance_map  # its default source (32) must not stop a small base_size the map does not read
    if rt.diffuse == "irradiance_map" and m.source_size > rt.base_size:
        raise SceneError(f"{where}: realtime.irradiance_map.source_size = {m.source_size}: must be at most "
                         f"realtime.base_size = {rt.base_size}")
    return rt


def _table_hint(name: str) -> str:
    return {"prefiltered": 'realtime.glossy = "prefiltered"', "irradiance_map": 'realtime.diffuse = "irradiance_map"',
            "lights": 'realtime.diffuse or realtime.glossy = "lights"',
            "prt": 'realtime.diffuse, occlusion or interreflection = "prt"',
            "vct": 'realtime.occlusion or interreflection = "vct"',
            "sphere_map": 'realtime.parameterization = "sphere_map"'}[name]


def _check_technique_tables(rt: Realtime, raw: dict, where: str) -> None:
    """Values of the light-array and transfer tables that only make sense with some choices."""
    from scenes.environment import light_array

    lights, prt = rt.lights, rt.prt
    given_lights, given_prt = raw.get("lights", {}), raw.get("prt", {})
    if "lights" in (rt.diffuse, rt.glossy):
        problem = light_array.count_problem(lights.placement, lights.count)
        if problem:
            raise SceneError(f"{where}: realtime.lights.count = {lights.count} with realtime.lights.placement = "
                             f"{lights.placement!r}: {problem}")
    if "shadow_map_size" in given_lights and rt.occlusion != "shadow_maps":
        raise SceneError(f"{where}: realtime.lights.shadow_map_size = {lights.shadow_map_size} with "
                         f"realtime.occlusion = {rt.occlusion!r}: shadow maps are drawn for "
                         'realtime.occlusion = "shadow_maps" only')
    texels = lights.count * lights.shadow_map_size ** 2
    if rt.occlusion == "shadow_maps" and texels > MAX_SHADOW_TEXELS:
        raise SceneError(f"{where}: realtime.lights.count = {lights.count} with realtime.lights.shadow_map_size = "
                         f"{lights.shadow_map_size}: {texels} shadow-map texels ({texels * 4 / 2**30:.2g} GiB); "
                         f"at most {MAX_SHADOW_TEXELS} (1 GiB): fewer lights or smaller maps")
    if rt.interreflection == "prt" and prt.bounces < 1:
        raise SceneError(f"{where}: realtime.interreflection = 'prt' with realtime.prt.bounces = {prt.bounces}: "
                         "interreflected transfer needs at least one bounce")
    if prt.bounces > 0 and rt.interreflection != "prt":
        raise SceneError(f"{where}: realtime.prt.bounces = {prt.bounces} with realtime.interreflection = "
                         f"{rt.interreflection!r}: bounces are gathered for realtime.interreflection = \"prt\" only")
    if "rays" in given_prt and rt.occlusion != "prt":
        raise SceneError(f"{where}: realtime.prt.rays = {prt.rays} with realtime.occlusion = {rt.occlusion!r}: "
                         'visibility rays are traced for realtime.occlusion = "prt" only (unshadowed transfer is '
                         "exact)")


def _check_combinations(rt: Realtime, given: dict, where: str) -> None:
    """Combinations that make no sense are errors naming both keys (design.md section 9)."""
    def bad(key_a: str, key_b: str, why: str) -> SceneError:
        return SceneError(f"{where}: realtime.{key_a} = {getattr(rt, key_a)!r} with realtime.{key_b} = "
                          f"{getattr(rt, key_b)!r}: {why}")

    if rt.occlusion == "shadow_maps" and "lights" not in (rt.diffuse, rt.glossy):
        raise bad("occlusion", "diffuse", 'shadow maps are cast by the light array: set realtime.diffuse or '
                  'realtime.glossy = "lights"')
    if rt.occlusion == "prt" and rt.diffuse != "prt":
        raise bad("occlusion", "diffuse", 'precomputed visibility lives in the transfer: set realtime.diffuse = "prt"')
    if rt.interreflection == "vct" and rt.occlusion != "vct":
        raise bad("interreflection", "occlusion", "light gathered from the voxels replaces the environment they "
                  'block: set realtime.occlusion = "vct"')
    if rt.interreflection == "prt" and (rt.diffuse != "prt" or rt.occlusion != "prt"):
        raise bad("interreflection", "occlusion", "interreflected transfer includes its shadowing: set "
                  'realtime.diffuse = "prt" and realtime.occlusion = "prt"')
    # the lobe-prefiltered chain and the irradiance map convolve the cube map: cube only
    if rt.parameterization != "cube":
        for key, value in (("glossy", "prefiltered"), ("diffuse", "irradiance_map")):
            if getattr(rt, key) == value:
                raise bad(key, "parameterization", f'realtime.{key} = "{value}" reads the cube map; set '
                          'realtime.parameterization = "cube" or choose another technique')
    # the paper's knobs of one technique, set explicitly while another technique is chosen
    if "sh_order" in given and rt.sh_order != 2 and rt.diffuse != "sh":
        raise bad("sh_order", "diffuse", 'the SH order applies to realtime.diffuse = "sh" only')
    if "sh_window" in given and rt.sh_window != "none" and rt.diffuse != "sh":
        raise bad("sh_window", "diffuse", 'SH windows apply to realtime.diffuse = "sh" only')
    for key in ("lod_bias", "lod_mapping"):
        if key in given and rt.glossy != "box" and getattr(rt, key) != getattr(Realtime, key):
            raise bad(key, "glossy", 'the paper\'s LOD rule applies to realtime.glossy = "box" only '
                      "(the prefiltered chain has [realtime.prefiltered] bias)")


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
