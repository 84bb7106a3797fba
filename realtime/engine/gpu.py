"""The paper's method on the GPU (moderngl): per-frame environment filtering and shading.

`EnvironmentFilter` owns the HDR cube map and rebuilds it every frame, as the paper does for
dynamic lighting: base level from the equirect map (turned about +Y), 2x2 box mip chain written by
a compute shader (`downsample.comp`, so the filter is exactly the paper's, not the driver's
choice), SH9 projection of the selected level and the irradiance matrices M (`sh_project.comp`,
`sh_reduce.comp`). `SceneDrawer` draws the environment behind the objects and shades the objects
with a program compiled for the scene's effects only.

All textures are 32-bit float: HDR values beyond half-float range (a 1e6 sun) are never stored in
16-bit formats.
"""

from __future__ import annotations

import math
import re
from functools import cache
from importlib import resources

import moderngl
import numpy as np

from realtime.engine import levels, limits, sh
from scenes.environment import cubemap, shbasis
from scenes.environment.directions import direction_to_uv, rotation_y
from scenes.model import materials
from scenes.storage.errors import PluginLoadError

_INCLUDE = re.compile(r'^#include "([\w.]+)"\s*$', re.M)
#: the package whose shaders/ folder holds the engine's GLSL (a technique's GLSL lives in its own package)
ENGINE = "realtime"
#: the marker lines of shade.vert and shade.frag that the chosen techniques' GLSL and entry calls replace
TECHNIQUES_MARK = "// @techniques\n"
SHADE_ENTRIES_MARK = "    // @shade entries\n"
VERTEX_ENTRIES_MARK = "    // @vertex entries\n"
#: the effect keys in the order their GLSL goes into the shading pass: visibility first (the light
#: array's lobes call the shadow maps' light_visibility), then the lobes
GLSL_ORDER = ("occlusion", "interreflection", "diffuse", "glossy")


@cache
def shader_text(name: str, package: str | None = None) -> str:
    """A GLSL file's text: in `package`'s folder (a technique's own), else the engine's realtime/shaders/."""
    if package is not None:
        own = resources.files(package).joinpath(name)
        if own.is_file():
            return own.read_text()
    return resources.files(ENGINE).joinpath(f"shaders/{name}").read_text()


def expand_includes(text: str, package: str | None = None) -> str:
    """`#include "file"` replaced by the file (recursively), looked up as `shader_text` does."""
    for _ in range(8):  # includes nest a few levels at most
        text, n = _INCLUDE.subn(lambda m: shader_text(m.group(1), package), text)
        if not n:
            break
    return text


def with_defines(text: str, defines: tuple[str, ...]) -> str:
    """`#define`s inserted after #version. A define is "NAME" or "NAME VALUE"."""
    head, _, rest = text.partition("\n")
    # two techniques may ask for the same define (the environment store's lookup): once each
    return head + "\n" + "".join(f"#define {d}\n" for d in dict.fromkeys(defines)) + rest


def shader_source(name: str, defines: tuple[str, ...] = (), package: str | None = None) -> str:
    """A shader's text (in `package`, a technique's, or the engine's folder) with its includes expanded and
    `defines` inserted."""
    return with_defines(expand_includes(shader_text(name, package), package), defines)


def shading_sources(declarations, defines: tuple[str, ...]) -> tuple[str, str]:
    """(shade.vert, shade.frag) for the chosen techniques' declarations: each file of their
    `vertex_glsl` / `fragment_glsl` once (two choices of one package share theirs), visibility first
    (GLSL_ORDER), and a call of each `vertex_entry` / `shade_entry` at its marker."""
    ordered = sorted(declarations, key=lambda d: GLSL_ORDER.index(d.effect))

    def files(attr: str) -> str:
        seen = dict.fromkeys((d.package, name) for d in ordered for name in getattr(d, attr))
        return "".join(expand_includes(shader_text(name, package), package) for package, name in seen)

    def calls(attr: str, args: str) -> str:
        names = dict.fromkeys(getattr(d, attr) for d in ordered if getattr(d, attr))
        return "".join(f"    {name}({args});\n" for name in names)

    vert = expand_includes(shader_text("shade.vert"))
    vert = vert.replace(TECHNIQUES_MARK, files("vertex_glsl")).replace(VERTEX_ENTRIES_MARK, calls("vertex_entry", ""))
    frag = expand_includes(shader_text("shade.frag"))
    frag = frag.replace(TECHNIQUES_MARK, files("fragment_glsl"))
    frag = frag.replace(SHADE_ENTRIES_MARK, calls("shade_entry", "n, v, Ld, Lg"))
    return with_defines(vert, defines), with_defines(frag, defines)


def compile_shading(ctx: moderngl.Context, declarations, defines: tuple[str, ...]) -> moderngl.Program:
    """The shading pass's program. Techniques that together sample more textures than the context allows are
    refused naming them (limits.GLLimitExceeded: exit 3). A plugin's GLSL that does not compile is the
    plugin's error (one line naming it, PluginLoadError); a builtin's is a bug and raised as it is."""
    vert, frag = shading_sources(declarations, defines)
    try:
        return ctx.program(vertex_shader=vert, fragment_shader=frag)
    except moderngl.Error as exc:
        chosen = " and ".join(f"realtime.{d.effect} = {d.name!r}" for d in declarations)
        refusal = limits.sampler_refusal(ctx, str(exc), chosen or "realtime")
        if refusal is not None:
            raise refusal from None
        plugins = [d for d in declarations if not d.builtin]
        if not plugins:
            raise
        log = next((line.strip() for line in str(exc).splitlines() if "error" in line.lower()), str(exc))
        raise PluginLoadError(f"{' and '.join(d.label for d in plugins)}: its GLSL does not compile in the "
                              f"shading pass: {' '.join(log.split())}") from None


def mat_bytes(m: np.ndarray) -> bytes:
    """A numpy (row-major) matrix as a GLSL (column-major) uniform."""
    return np.ascontiguousarray(np.asarray(m, dtype=np.float64).T, dtype="f4").tobytes()


def world_to_env(rotation_deg: float) -> np.ndarray:
    return rotation_y(rotation_deg).T  # inverse of the environment's to_world rotation


def fill_from_equirect(ctx: moderngl.Context, prog, env_tex, texel_uv, target, size: int, layers: int,
                       rotation_deg: float) -> None:
    """Level 0 of an environment store (cube faces or 2D map layers) from the equirect map turned by
    `rotation_deg` about +Y: a turn only shifts the map's u, so each texel's precomputed (u, v) in
    `texel_uv` plus the shift gives its lookup (env_to_cube.comp, map_fill.comp)."""
    env_tex.use(0)
    texel_uv.use(1)
    prog["env"] = 0
    prog["texel_uv"] = 1
    prog["u_shift"] = (rotation_deg / 360.0) % 1.0
    prog["size"] = size
    target.bind_to_image(0, read=False, write=True, level=0)
    prog.run(groups(size), groups(size), layers)
    ctx.memory_barrier()


def groups(n: int, local: int = 8) -> int:
    return (n + local - 1) // local


class EnvironmentFilter:
    """HDR cube map + mip chain + SH9 of one environment, refiltered on demand.

    The `cube` environment store; realtime/engine/environment_maps.py has the others, with the same API."""

    parameterization = "cube"

    def __init__(self, ctx: moderngl.Context, env: np.ndarray, base_size: int) -> None:
        self.ctx = ctx
        self.base_size = base_size
        self.n_levels = int(math.log2(base_size)) + 1
        self.radiance = env  # the equirect map as uploaded (fitted to the context's limits by environment_store)
        limits.clear_errors(ctx)  # the GL error flag is checked once all is made (limits.check_created)
        h, w = env.shape[:2]
        limits.check_texture(ctx, "2d", (w, h), "environment.map", "the environment map")
        limits.check_texture(ctx, "cube", (base_size, base_size), "realtime.base_size", "the cube map")
        limits.check_texture(ctx, "array", (base_size, base_size, 6), "realtime.base_size",
                             "the cube map's texel lookup table")
        self.env_tex = ctx.texture((w, h), 3, np.ascontiguousarray(env, dtype="f4").tobytes(), dtype="f4")
        self.env_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)  # bilinear is done by hand
        self.cube = ctx.texture_cube((base_size, base_size), 4, dtype="f4")
        self.cube.build_mipmaps()  # allocates every level; their contents are written below
        limits.check_created(ctx, "realtime.base_size", f"the {base_size}-texel cube map and its mip chain")
        self.cube.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        self.fill_prog = ctx.compute_shader(shader_source("env_to_cube.comp"))
        self.down_prog = ctx.compute_shader(shader_source("downsample.comp"))
        self.sh_prog = self.reduce_prog = None  # the SH9 programs, compiled on the first project_sh
        u, v = direction_to_uv(cubemap.texel_directions(base_size))
        uv = np.stack([u, v], axis=-1).reshape(6, base_size, base_size, 2).astype("f4")
        # one layer per face: a (size, 6 size) 2D texture would pass GL_MAX_TEXTURE_SIZE at a sixth of the cube's size
        self.texel_uv = ctx.texture_array((base_size, base_size, 6), 2, uv.tobytes(), dtype="f4")
        self.texel_uv.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.sh_buffer = ctx.buffer(reserve=(3 * 16 + 9 * 4) * 4)
        self._solid_angle: dict[int, moderngl.Texture] = {}
        self._partials: dict[int, moderngl.Buffer] = {}
        limits.check_created(ctx, "realtime.base_size", f"the {base_size}-texel cube map's lookup table")
        self.filled = 0  # fill_base calls so far: the solid-angle chain is rebuilt when it lags
        self.solid_angle_cube: moderngl.TextureCube | None = None  # solid_angle_chain's cube, made on first use
        self.solid_angle_filled = -1
        self.solid_angle_prog: moderngl.ComputeShader | None = None

    # -- per-frame work --------------------------------------------------------------------
    def fill_base(self, rotation_deg: float) -> None:
        fill_from_equirect(self.ctx, self.fill_prog, self.env_tex, self.texel_uv, self.cube, self.base_size, 6,
                           rotation_deg)
        self.filled += 1

    def build_chain(self, down_to_level: int | None = None) -> None:
        """2x2 box-filter levels 1 .. down_to_level (default: down to 1x1)."""
        self._box_chain(self.cube, self.n_levels - 1 if down_to_level is None else down_to_level)

    def _box_chain(self, cube: moderngl.TextureCube, last: int) -> None:
        """Levels 1 .. last of `cube`, each texel the mean of a 2x2 block of the level below (downsample.comp)."""
        for level in range(1, last + 1):
            size = self.base_size >> level
            cube.bind_to_image(0, read=True, write=False, level=level - 1)
            cube.bind_to_image(1, read=False, write=True, level=level)
            self.down_prog["dst_size"] = size
            self.down_prog.run(groups(size), groups(size), 6)
            self.ctx.memory_barrier()

    def project_sh(self, face_size: int, window=(1.0, 1.0, 1.0)) -> None:
        """The paper's SH9 of the level of `face_size` and its matrices M, into `sh_buffer`."""
        if self.sh_prog is None:  # compiled only for scenes whose diffuse technique is SH9
            self.sh_prog = self.ctx.compute_shader(shader_source("sh_project.comp", sh9_defines()))
            self.reduce_prog = self.ctx.compute_shader(shader_source("sh_reduce.comp", sh9_defines()))
        level = levels.level_of(face_size, self.base_size)
        block = max(1, min(4, face_size // 8))  # texels per invocation along each axis
        tiles = groups(face_size, 8 * block)
        n_groups = 6 * tiles * tiles
        partial = self._partials.get(face_size)
        if partial is None:
            partial = self._partials[face_size] = self.ctx.buffer(reserve=n_groups * 9 * 16)
        self.cube.bind_to_image(0, read=True, write=False, level=level)
        self._solid_angle_texture(face_size).use(1)
        self.sh_prog["solid_angle"] = 1
        self.sh_prog["size"] = face_size
        self.sh_prog["block"] = block
        partial.bind_to_storage_buffer(1)
        self.sh_prog.run(tiles, tiles, 6)
        self.ctx.memory_barrier()
        self.reduce_prog["n_groups"] = n_groups
        self.reduce_prog["window"].write(np.asarray(window, dtype="f4").tobytes())
        self.sh_buffer.bind_to_storage_buffer(2)
        self.reduce_prog.run(1, 1, 1)
        self.ctx.memory_barrier()

    def _solid_angle_texture(self, size: int) -> moderngl.Texture:
        """Each texel's exact solid angle on a face of `size` texels (all six alike; R32F), made once per size."""
        tex = self._solid_angle.get(size)
        if tex is None:
            omega = cubemap.texel_solid_angles(size).astype("f4")
            tex = self._solid_angle[size] = self.ctx.texture((size, size), 1, omega.tobytes(), dtype="f4")
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return tex

    def solid_angle_chain(self) -> moderngl.TextureCube:
        """The cube's chain weighted by solid angle, for reads that must keep the environment's mean radiance over
        wide regions (voxel cone tracing's): texels (rgb w, w), w each base texel's solid angle, box-filtered as
        the paper's chain is (a level's alpha is then its texels' mean solid angle per base texel); a read's
        rgb / a is the solid-angle-weighted mean.

        Why: a texel of level L should hold the mean radiance over the solid angle it covers,
        sum_c L_c Omega_c / sum_c Omega_c over its base texels c. The paper's 2x2 box mean is that only where the
        texels' solid angles are equal; a cube face's centre texel covers 3 sqrt(3) = 5.2 times a corner texel's,
        so the coarse levels weigh the corners as the centres and miss the mean wherever the light is not spread
        evenly over the face (under the Ennis probe the 1x1 level's solid-angle-weighted mean radiance is 0.71 of
        the environment's). Built from level 0 after each fill_base, on the first call after it."""
        if self.solid_angle_cube is None:
            self.solid_angle_cube = self.ctx.texture_cube((self.base_size, self.base_size), 4, dtype="f4")
            self.solid_angle_cube.build_mipmaps()
            limits.check_created(self.ctx, "realtime.base_size", "the solid-angle-weighted cube chain")
            self.solid_angle_cube.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
            self.solid_angle_prog = self.ctx.compute_shader(shader_source("solid_angle_weight.comp"))
        if self.solid_angle_filled != self.filled:
            self.cube.bind_to_image(0, read=True, write=False, level=0)
            self.solid_angle_cube.bind_to_image(1, read=False, write=True, level=0)
            self._solid_angle_texture(self.base_size).use(0)
            self.solid_angle_prog["solid_angle"] = 0
            self.solid_angle_prog["size"] = self.base_size
            self.solid_angle_prog.run(groups(self.base_size), groups(self.base_size), 6)
            self.ctx.memory_barrier()
            self._box_chain(self.solid_angle_cube, self.n_levels - 1)
            self.solid_angle_filled = self.filled
        return self.solid_angle_cube

    # -- the glossy lookup (glossy_box.glsl reads env_cube) ----------------------------------
    def lookup_defines(self) -> tuple[str, ...]:
        return ()

    def bind_lookup(self, prog: moderngl.Program, unit: int, cube_uniform: str = "env_cube") -> None:
        """The store on `unit`, read through the sampler `cube_uniform` (voxel cone tracing's is its own)."""
        self.cube.use(unit)
        _set(prog, cube_uniform, unit)

    def meta(self) -> dict:
        return {"environment_store": {"parameterization": "cube", "face_size": self.base_size, "layers": 6,
                                      "texels": 6 * self.base_size ** 2}}

    # -- read-backs (tests, meta) -----------------------------------------------------------
    def read_sh(self) -> tuple[np.ndarray, np.ndarray]:
        """(coeffs (9, 3), M (3, 4, 4)) as last computed on the GPU."""
        data = np.frombuffer(self.sh_buffer.read(), dtype="f4")
        M = data[:48].reshape(3, 4, 4).transpose(0, 2, 1)  # column-major storage
        coeffs = data[48:].reshape(9, 4)[:, :3]
        return coeffs.astype(np.float64), M.astype(np.float64)

    def read_level(self, level: int, weighted: bool = False) -> np.ndarray:
        """Faces (6, s, s, 3) of one mip level; `weighted`: of `solid_angle_chain`'s, (6, s, s, 4) = (rgb w, w)."""
        size = self.base_size >> level
        prog = self.ctx.compute_shader(shader_source("dump_level.comp"))
        out = self.ctx.buffer(reserve=6 * size * size * 16)
        (self.solid_angle_chain() if weighted else self.cube).bind_to_image(0, read=True, write=False, level=level)
        out.bind_to_storage_buffer(3)
        prog["size"] = size
        prog.run(groups(size), groups(size), 6)
        self.ctx.memory_barrier()
        arr = np.frombuffer(out.read(), dtype="f4").reshape(6, size, size, 4)[..., :4 if weighted else 3].copy()
        out.release()
        prog.release()
        return arr

    def release(self) -> None:
        for obj in [self.env_tex, self.texel_uv, self.cube, self.fill_prog, self.down_prog, self.sh_prog,
                    self.reduce_prog, self.sh_buffer, *self._solid_angle.values(), *self._partials.values(),
                    self.solid_angle_cube, self.solid_angle_prog]:
            if obj is not None:
                obj.release()


def sh9_defines() -> tuple[str, ...]:
    """The SH9 basis constants (scenes/environment/shbasis.py) and the paper's c1..c5 (realtime/engine/sh.py) as
    #defines: the constants live once, in Python."""
    basis = (f"SH_C{i} {c!r}" for i, c in enumerate((shbasis.C0, shbasis.C1, shbasis.C2, shbasis.C3, shbasis.C4)))
    paper = (f"SH_M{i} {c!r}" for i, c in enumerate((sh.C1, sh.C2, sh.C3, sh.C4, sh.C5), start=1))
    return (*basis, *paper)


class SceneDrawer:
    """Draws the environment background and the scene's objects into a float32 RGBA target, with a
    shading program compiled for the scene's effects and techniques only."""

    def __init__(self, ctx: moderngl.Context, scene, env_filter: EnvironmentFilter, techniques=()) -> None:
        self.ctx = ctx
        self.scene = scene
        self.filter = env_filter
        self.techniques = list(techniques)
        cam = scene.camera
        self.width, self.height = cam.width, cam.height
        effects = tuple(f"HAS_{e.upper()}" for e in ("diffuse", "glossy", "fresnel") if e in scene.effects)
        extra = tuple(d for t in self.techniques for d in t.defines())
        # realtime.reflection = "per_vertex": the mirror direction is computed in shade.vert and interpolated
        per_vertex = scene.realtime.reflection == "per_vertex" and "glossy" in scene.effects
        reflection = ("REFLECTION_PER_VERTEX",) if per_vertex else ()
        self.defines = effects + extra + reflection + materials.glsl_defines()
        self.prog = compile_shading(ctx, [t.declaration for t in self.techniques], self.defines)
        self.bg_prog = ctx.program(vertex_shader=shader_source("fullscreen.vert"),
                                   fragment_shader=shader_source("background.frag"))
        self.bg_vao = ctx.vertex_array(self.bg_prog, [])
        limits.check_texture(ctx, "framebuffer", (self.width, self.height), "camera.width x camera.height",
                             "the image")
        limits.clear_errors(ctx)
        self.color = ctx.texture((self.width, self.height), 4, dtype="f4")
        self.depth = ctx.depth_renderbuffer((self.width, self.height))
        self.fbo = ctx.framebuffer(color_attachments=[self.color], depth_attachment=self.depth)
        limits.check_created(ctx, "camera.width x camera.height", "the image's framebuffer")
        self.objects = []
        for obj in scene.objects:
            mesh = obj.mesh
            vbo = ctx.buffer(np.hstack([mesh.positions, mesh.normals]).astype("f4").tobytes())
            ibo = ctx.buffer(mesh.indices.astype("i4").tobytes())
            vao = ctx.vertex_array(self.prog, [(vbo, "3f 3f", "in_position", "in_normal")], index_buffer=ibo)
            self.objects.append((obj, vbo, ibo, vao))
        near, far = cam.depth_range([obj.mesh.positions for obj in self.scene.objects])
        self.view_proj = cam.projection_matrix(near, far) @ cam.view_matrix()

    def draw_background(self, rotation_deg: float) -> None:
        """Clear the target and draw the environment behind everything (alpha 0 = not covered).

        Not part of the method under test (and masked out of metrics): timed as `background`."""
        ctx = self.ctx
        self.fbo.use()
        ctx.viewport = (0, 0, self.width, self.height)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        self.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self.filter.env_tex.use(0)
        self.bg_prog["env"] = 0
        self.bg_prog["inv_view_proj"].write(mat_bytes(np.linalg.inv(self.view_proj)))
        self.bg_prog["world_to_env"].write(mat_bytes(world_to_env(rotation_deg)))
        self.bg_vao.render(moderngl.TRIANGLES, vertices=3)

    def draw(self) -> None:
        """The shading pass: every object, depth-tested (`draw`)."""
        ctx = self.ctx
        self.fbo.use()
        ctx.viewport = (0, 0, self.width, self.height)
        ctx.enable(moderngl.DEPTH_TEST)
        p = self.prog
        for t in self.techniques:
            t.bind(p)
        p["view_proj"].write(mat_bytes(self.view_proj))
        _set(p, "camera_position", tuple(self.scene.camera.origin))
        for obj, _, _, vao in self.objects:
            m = obj.material
            _set(p, "material_type", materials.of(m).code)
            _set(p, "kd", m.kd)
            _set(p, "ks", m.ks)
            _set(p, "f0", m.f0)
            _set(p, "two_sided", int(m.two_sided))
            _set(p, "base_color", m.base_color)
            _set(p, "metallic", m.metallic)
            _set(p, "roughness", m.roughness)
            for t in self.techniques:
                t.bind_object(p, obj)
            vao.render(moderngl.TRIANGLES)

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """(rgb (H, W, 3) float32, mask (H, W) bool), row 0 at the top."""
        data = np.frombuffer(self.fbo.read(components=4, dtype="f4"), dtype="f4")
        img = data.reshape(self.height, self.width, 4)[::-1]  # OpenGL row 0 is the bottom
        return np.ascontiguousarray(img[..., :3]), img[..., 3] > 0.5

    def release(self) -> None:
        for _, vbo, ibo, vao in self.objects:
            vao.release()
            vbo.release()
            ibo.release()
        for r in [self.prog, self.bg_prog, self.bg_vao, self.color, self.depth, self.fbo]:
            r.release()


def _set(prog: moderngl.Program, name: str, value) -> None:
    """Set a uniform if the compiled program kept it (unused ones are optimised away)."""
    if name in prog:
        prog[name] = value
