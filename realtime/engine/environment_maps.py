"""How the environment texture is stored and filtered (`realtime.parameterization`, docs/contract.md section 9).

    cube             the paper's (Greene 1986): realtime.engine.gpu.EnvironmentFilter, unchanged
    dual_paraboloid  Heidrich & Seidel 1998: two maps of the hemispheres z >= 0 and z < 0 (world frame)
    sphere_map       OpenGL's GL_SPHERE_MAP: one map made for a capture view (`[realtime.sphere_map]
                     capture`, default "camera")

Every store has the small API of EnvironmentFilter, which the techniques and realtime/engine/frame.py use:
`fill_base(rotation_deg)` (per frame, from the equirect map through `scenes`' lookup), `build_chain(to)`
(the paper's 2x2 box filter, level by level), `project_sh(face_size, window)` (SH9 with the exact
texel solid angles of the parameterization, the paper's M into `sh_buffer`), `read_sh`, `read_level`,
`lookup_defines()` and `bind_lookup(prog, unit)` for the glossy lookup (shaders/env_map.glsl), `meta()`.

Budgets: `realtime.base_size` and `face_size` keep their meaning, the texel budget of a cube with
faces of that size (6 s^2 texels); a 2D parameterization stores the same budget rounded to a power
of two (scenes/environment/paraboloid.py, scenes/environment/spheremap.py `map_size`: 2 s, so two maps of 8 s^2
texels or
one of 4 s^2), and its mip levels keep the cube's indices (level l has side (2 base) >> l).

Mappings and texel solid angles are pure numpy in scenes/ (paraboloid.py, spheremap.py, discmap.py);
the GPU reads them as float64-made textures (texel (u, v) for the fill, directions and solid angles for
the SH projection), so the GLSL mirrors only the lookup (env_map.glsl).
"""

from __future__ import annotations

import math
from types import ModuleType

import moderngl
import numpy as np

from realtime.engine import levels, limits
from realtime.engine.gpu import EnvironmentFilter, fill_from_equirect, groups, mat_bytes, sh9_defines, shader_source
from realtime.engine.sh_orders import project_and_reduce
from scenes.environment import paraboloid, spheremap
from scenes.environment.directions import direction_to_uv
from scenes.environment.shbasis import count, glsl_defines

#: the 2D parameterizations by their `realtime.parameterization` value (cube: realtime.engine.gpu)
MAPPINGS: dict[str, ModuleType] = {"dual_paraboloid": paraboloid, "sphere_map": spheremap}
#: every value of `realtime.parameterization` this module can build
STORES = ("cube", *MAPPINGS)
#: the GLSL define that selects each mapping in env_map.glsl
DEFINES = {"dual_paraboloid": "ENV_DUAL_PARABOLOID", "sphere_map": "ENV_SPHERE_MAP"}
TEXEL_DIR_UNIT = 1


def environment_store(ctx: moderngl.Context, scene):
    """The scene's environment store: the paper's cube map, or a 2D parameterization."""
    rt = scene.realtime
    env = limits.fit_equirect(ctx, scene.environment.radiance(), f"environment.map = {scene.environment.map!r}")
    if rt.parameterization == "cube":
        return EnvironmentFilter(ctx, env, rt.base_size)
    return MapStore(ctx, env, rt.base_size, MAPPINGS[rt.parameterization], map_frame(scene))


def filled_store(ctx: moderngl.Context, scene, sh_face_size: int = 64):
    """The scene's environment store (`environment_store`) filled as a frame fills it, for work outside a frame
    (a voxel scene's injection, measurements): the base at the map's rotation, the whole box chain, and the SH9
    projected from a `sh_face_size`^2 filter. The caller releases it."""
    env = environment_store(ctx, scene)
    try:
        env.fill_base(scene.environment.rotation_deg)
        env.build_chain(None)
        env.project_sh(sh_face_size)
    except BaseException:
        env.release()
        raise
    return env


def map_frame(scene) -> np.ndarray:
    """World -> map rotation (3, 3): the identity for the dual paraboloid; the capture view's eye space
    for the sphere map (`capture = "camera"`: the scene camera; a direction: a camera looking along it
    with the scene camera's up)."""
    rt = scene.realtime
    if rt.parameterization != "sphere_map":
        return np.eye(3)
    cam = scene.camera
    capture = rt.sphere_map.capture
    forward = np.subtract(cam.target, cam.origin) if capture == "camera" else np.asarray(capture, dtype=np.float64)
    return spheremap.capture_frame(forward, cam.up)


def lod_offset(mapping: ModuleType, base_size: int) -> float:
    """0.5 log2(Omega_ref / A0): Omega_ref = 4 pi / (6 base^2), the cube's mean level-0 texel solid
    angle; A0 = (2 / m)^2, the plane area of a level-0 texel of the map (side m). A lookup at plane
    position p then reads level lod + lod_offset - 0.5 log2(dOmega/dA(p)): the level whose texel there
    covers the solid angle of the cube's mean texel at `lod` (env_map.glsl)."""
    m = mapping.map_size(base_size)
    omega_ref = 4.0 * math.pi / (6.0 * base_size * base_size)
    return 0.5 * math.log2(omega_ref / (2.0 / m) ** 2)


def texel_lod(mapping: ModuleType, base_size: int, lod: float, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The level env_map.glsl reads at plane positions (x, y) for a host LOD `lod` (numpy mirror)."""
    m = mapping.map_size(base_size)
    level = lod + lod_offset(mapping, base_size) - 0.5 * np.log2(mapping.density(x, y))
    return np.clip(level, 0.0, math.log2(m))


class MapShProjector:
    """SH projection of one level of a MapStore's texture array (map_sh_project.comp).

    `paper=True` (order 2): the paper's reduction (sh_reduce.comp: coefficients and M) into the buffer
    given, the layout of EnvironmentFilter.sh_buffer. Otherwise orders 2..4 with sh_reduce_n.comp into
    its own `buffer` (coeffs, weighted: realtime/engine/sh_orders.py's layout), read by `read()`.
    """

    def __init__(self, ctx: moderngl.Context, order: int, paper: bool = False, buffer=None) -> None:
        self.ctx, self.order, self.count = ctx, order, count(order)
        self.project_prog = ctx.compute_shader(shader_source("map_sh_project.comp", glsl_defines(order)))
        if paper:
            if order != 2:
                raise ValueError("the paper's reduction is SH9 (order 2)")
            self.reduce_prog = ctx.compute_shader(shader_source("sh_reduce.comp", sh9_defines()))
        else:
            self.reduce_prog = ctx.compute_shader(shader_source("sh_reduce_n.comp", glsl_defines(order)))
        self.owns_buffer = buffer is None
        self.buffer = buffer if buffer is not None else ctx.buffer(reserve=2 * self.count * 16)
        self._partials: dict[int, moderngl.Buffer] = {}

    def run(self, store: MapStore, level: int, face_size: int, window_factors=None) -> None:
        size = store.size >> level
        if level != levels.level_of(face_size, store.base_size):
            raise ValueError(f"level {level} does not hold the budget of face size {face_size}")
        sigma = np.ones(self.order + 1) if window_factors is None else np.asarray(window_factors, dtype=np.float64)
        if sigma.shape != (self.order + 1,):
            raise ValueError(f"order {self.order} needs {self.order + 1} window factors, got shape {sigma.shape}")
        block = max(1, min(4, size // 8))
        tiles = groups(size, 8 * block)
        n_groups = store.layers * tiles * tiles
        partial = self._partials.get(size)
        if partial is None:
            partial = self._partials[size] = self.ctx.buffer(reserve=n_groups * self.count * 16)
        store.texture.bind_to_image(0, read=True, write=False, level=level)
        store.texel_dir_texture(level).use(TEXEL_DIR_UNIT)
        self.project_prog["texel_dir"] = TEXEL_DIR_UNIT
        self.project_prog["size"] = size
        self.project_prog["block"] = block
        project_and_reduce(self.ctx, self.project_prog, self.reduce_prog, partial, self.buffer, tiles, store.layers,
                           n_groups, sigma)

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """(coeffs (n, 3), weighted (n, 3)) as last computed (not for `paper=True`)."""
        data = np.frombuffer(self.buffer.read(), dtype="f4").reshape(2, self.count, 4)[..., :3]
        return data[0].astype(np.float64), data[1].astype(np.float64)

    def release(self) -> None:
        for obj in [self.project_prog, self.reduce_prog, *self._partials.values()]:
            obj.release()
        if self.owns_buffer:
            self.buffer.release()
        self._partials.clear()


class MapStore:
    """A 2D parameterization of the environment (texture array of 1 or 2 layers, full mip chain),
    refiltered on demand, with EnvironmentFilter's API (module docstring)."""

    def __init__(self, ctx: moderngl.Context, env: np.ndarray, base_size: int, mapping: ModuleType,
                 frame: np.ndarray) -> None:
        self.ctx = ctx
        self.mapping = mapping
        self.parameterization = mapping.NAME
        self.base_size = base_size  # the cube-equivalent budget of level 0
        self.size = mapping.map_size(base_size)
        self.layers = mapping.LAYERS
        self.n_levels = int(math.log2(self.size)) + 1
        self.frame = np.asarray(frame, dtype=np.float64)  # world -> map
        self.radiance = env  # the equirect map as uploaded (fitted to the context's limits by environment_store)
        limits.clear_errors(ctx)  # the GL error flag is checked once all is made (limits.check_created)
        h, w = env.shape[:2]
        limits.check_texture(ctx, "2d", (w, h), "environment.map", "the environment map")
        limits.check_texture(ctx, "array", (self.size, self.size, self.layers), "realtime.base_size",
                             f"the {self.parameterization} map")
        self.env_tex = ctx.texture((w, h), 3, np.ascontiguousarray(env, dtype="f4").tobytes(), dtype="f4")
        self.env_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)  # bilinear is done by hand
        self.texture = ctx.texture_array((self.size, self.size, self.layers), 4, dtype="f4")
        self.texture.build_mipmaps()  # allocates every level; their contents are written below
        limits.check_created(ctx, "realtime.base_size", f"the {self.parameterization} map and its mip chain")
        self.texture.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        self.texture.repeat_x = self.texture.repeat_y = False
        self.fill_prog = ctx.compute_shader(shader_source("map_fill.comp"))
        self.down_prog = ctx.compute_shader(shader_source("map_downsample.comp"))
        u, v = direction_to_uv(self.world_directions(self.size))
        uv = np.stack([u, v], axis=-1).reshape(self.layers, self.size, self.size, 2).astype("f4")
        self.texel_uv = ctx.texture_array((self.size, self.size, self.layers), 2, uv.tobytes(), dtype="f4")
        self.texel_uv.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.sh_buffer = ctx.buffer(reserve=(3 * 16 + 9 * 4) * 4)
        self.projector = MapShProjector(ctx, 2, paper=True, buffer=self.sh_buffer)
        self._texel_dir: dict[int, moderngl.Texture] = {}
        limits.check_created(ctx, "realtime.base_size", f"the {self.parameterization} map's lookup table")

    def world_directions(self, size: int) -> np.ndarray:
        """World directions (layers, size, size, 3) of the texel centres of a level of side `size`."""
        return self.mapping.texel_directions(size) @ self.frame  # rows: frame^T d

    def texel_dir_texture(self, level: int) -> moderngl.Texture:
        """(size, layers size) RGBA32F: world direction and exact solid angle of every texel of a level."""
        tex = self._texel_dir.get(level)
        if tex is None:
            size = self.size >> level
            data = np.concatenate([self.world_directions(size),
                                   self.mapping.texel_solid_angles(size)[..., None]], axis=-1)
            data = data.reshape(self.layers * size, size, 4).astype("f4")
            limits.check_texture(self.ctx, "2d", (size, self.layers * size), "realtime.base_size",
                                 "the map's texel directions")
            tex = self.ctx.texture((size, self.layers * size), 4, data.tobytes(), dtype="f4")
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self._texel_dir[level] = tex
        return tex

    # -- per-frame work --------------------------------------------------------------------
    def fill_base(self, rotation_deg: float) -> None:
        fill_from_equirect(self.ctx, self.fill_prog, self.env_tex, self.texel_uv, self.texture, self.size,
                           self.layers, rotation_deg)

    def build_chain(self, down_to_level: int | None = None) -> None:
        """2x2 box-filter levels 1 .. down_to_level (default: down to 1x1)."""
        last = self.n_levels - 1 if down_to_level is None else min(down_to_level, self.n_levels - 1)
        for level in range(1, last + 1):
            size = self.size >> level
            self.texture.bind_to_image(0, read=True, write=False, level=level - 1)
            self.texture.bind_to_image(1, read=False, write=True, level=level)
            self.down_prog["dst_size"] = size
            self.down_prog.run(groups(size), groups(size), self.layers)
            self.ctx.memory_barrier()

    def project_sh(self, face_size: int, window=(1.0, 1.0, 1.0)) -> None:
        """SH9 of the level that holds the budget of `face_size`, and the paper's M, into sh_buffer."""
        self.projector.run(self, levels.level_of(face_size, self.base_size), face_size, window)

    # -- the glossy lookup (env_map.glsl) ---------------------------------------------------
    def lookup_defines(self) -> tuple[str, ...]:
        return (DEFINES[self.parameterization], f"ENV_LOD_OFFSET {lod_offset(self.mapping, self.base_size)!r}",
                f"ENV_MAX_LOD {float(self.n_levels - 1)!r}")

    def bind_lookup(self, prog: moderngl.Program, unit: int, cube_uniform: str = "env_cube") -> None:
        """The store on `unit`, read through env_map.glsl's own uniforms (`cube_uniform` is the cube store's)."""
        self.texture.use(unit)
        if "env_map" in prog:
            prog["env_map"] = unit
        if "env_frame" in prog:
            prog["env_frame"].write(mat_bytes(self.frame))

    # -- read-backs (tests, meta) -----------------------------------------------------------
    def read_sh(self) -> tuple[np.ndarray, np.ndarray]:
        """(coeffs (9, 3), M (3, 4, 4)) as last computed on the GPU."""
        data = np.frombuffer(self.sh_buffer.read(), dtype="f4")
        M = data[:48].reshape(3, 4, 4).transpose(0, 2, 1)
        coeffs = data[48:].reshape(9, 4)[:, :3]
        return coeffs.astype(np.float64), M.astype(np.float64)

    def read_level(self, level: int) -> np.ndarray:
        """Maps (layers, s, s, 3) of one mip level."""
        size = self.size >> level
        prog = self.ctx.compute_shader(shader_source("map_dump_level.comp"))
        out = self.ctx.buffer(reserve=self.layers * size * size * 16)
        self.texture.bind_to_image(0, read=True, write=False, level=level)
        out.bind_to_storage_buffer(3)
        prog["size"] = size
        prog.run(groups(size), groups(size), self.layers)
        self.ctx.memory_barrier()
        arr = np.frombuffer(out.read(), dtype="f4").reshape(self.layers, size, size, 4)[..., :3].copy()
        out.release()
        prog.release()
        return arr

    def meta(self) -> dict:
        return {"environment_store": {"parameterization": self.parameterization, "map_size": self.size,
                                      "layers": self.layers, "texels": self.mapping.texel_count(self.size),
                                      "cube_equivalent_face": self.base_size,
                                      "cube_texels": 6 * self.base_size ** 2,
                                      "lod_offset": lod_offset(self.mapping, self.base_size)}}

    def release(self) -> None:
        self.projector.release()
        for obj in [self.env_tex, self.texel_uv, self.texture, self.fill_prog, self.down_prog, self.sh_buffer,
                    *self._texel_dir.values()]:
            obj.release()
