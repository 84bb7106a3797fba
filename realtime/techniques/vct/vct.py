"""Voxel cone tracing through cascaded anisotropic voxel textures: `realtime.occlusion = "vct"`,
`realtime.interreflection = "vct"`, `[realtime.vct] resolution, cascades, diffuse_cones, step, bounces`.

The voxel scene (`VoxelScene`, one per frame in `frame.shared["vct"]`, made by whichever VCT technique
asks first): `cascades` nested cubic grids of `resolution`^3 voxels, each twice the extent of the one
inside it, centred on the objects' bounding box (our cameras look at the objects from outside, so the
finest grid goes where the geometry is; realtime/techniques/vct/vct_math.py: `Cascades`, the outermost holding the
box with a 10% margin). `cascades = 1` is a plain 3D texture over the same extent.

Storage: six RGBA16F 3D textures, one per face direction (+X, -X, +Y, -Y, +Z, -Z: what leaves a voxel
toward it; rgb radiance premultiplied by alpha, a the opacity: the surfaces' coverage along the face's
axis), the cascades stacked along z, each face with its anisotropic mip chain; one RGBA16F column
texture (rgb: the coverage along x, y, z, max-mipped) for the cones' finer read; and six RGBA8 face-normal
textures (the mean normal of the surfaces facing each face, 0 where none does; bytes 128 + 127 n; alpha how
far their normals spread about it: sqrt(1 - l), l their unit normals' mean cosine about it),
mipped like the faces: 7 x 8 + 6 x 4 = 80 bytes per voxel at every level (the seed stores the finest level
isotropically; here it is six-face too, so that a thin wall's two sides stay apart).

Every frame (timed `voxelize`, its mips as `mip`):
1. voxelise (vct_voxelize.comp): one compute invocation per triangle and cascade, a conservative
   triangle/box test over its bounding box; integer atomics sum per voxel the count, the reflectance
   (kd, ks, exponent, f0, Schlick flag: `reflectance_of`) and per face direction a_f the weight
   max(0, n . a_f) and the weighted normal (the normal-weighted scheme: the mean of a thin wall's normals
   would face nowhere);
2. face normals (vct_normals.comp): each face's mean normal of the surfaces facing it, mipped
   (vct_normal_mip.comp) with the faces' opacities once a frame, after the coverage pass's face mips (the
   bounce passes change the faces' radiance, not their opacities);
   coverage (vct_inject.comp, inject = 0): each face's alpha = the surface's coverage of the voxel's
   cross-section along the face's axis (|n_a| / |n|_inf: a plane is transparent along itself), then its
   mips; the same coverages into the column texture (one channel per axis), max-mipped
   (vct_column_mip.comp): the most covered column of a texel, the cones' finer read;
3. injection (inject = 1): each face holds the surface's radiance toward a_f, the paper's reflectance
   (1 - F) kd / pi E V_d + F ks L_g(r) V_g (E the environment's SH9 irradiance, the scene's own when
   `diffuse = "sh"` with the paper's order, otherwise the environment filter's SH9 of the same level; L_g
   the environment convolved with the Phong lobe about the mirror direction r (vct_glossy_env.glsl: the
   broad-lobe table, lobe_table.py, or the environment's chain at the lobe's level); V_d the diffuse cones'
   visibility through the voxels themselves, V_g that of one cone along r with the lobe's half-angle: the
   direct pass reads every level, the bounce passes mips >= 1, as level 0's radiance is being written).
   Faced faces carry the full radiance, the others none, each times its axis's coverage (premultiplied;
   vct_inject.comp derives each). Then the radiance mips. `bounces` = k re-injects k - 1 times, adding what the
   cones gather from the previous bounce.
   The deferred glossy read (`deferred_glossy`: a scene with glossy surfaces under the frame's environment
   store, and interreflection on): the faces leave out the glossy term's environment part L_g(r) V_g, and an
   RGBA16F gloss texture holds per face the lobe's weight F ks V_g and its exponent (the six faces side by side
   along x: one image unit, where OpenGL drivers may offer 8; 48 bytes a voxel more), mipped as the radiance
   is; a cone reading a face evaluates the surfaces' lobe toward itself, F ks V_g H L_g(reflect(d, m)), m the
   face's stored normal (vct_trace.glsl's vct_gloss_radiance), where six stored directions would hand it the
   blend of six reflections; the lobe it reads broadened by the cone's aperture and by the spread of the
   normals the face stands for (the stored l), so that a cone reads the mean of the reflections over its
   directions and the texel's surfaces, not one sharp lobe.
   Occlusion alone (no `interreflection = "vct"`) reads the voxels' opacities only, all written in step 2: step 3,
   its SH9 projection and the environment's reads behind the glossy lobe are not run (`radiance`).

Shading (vct.glsl in shade.frag): occlusion multiplies the environment's diffuse irradiance by the diffuse
cones' cosine-weighted visibility and its glossy radiance by the glossy cone's (half-angle from the Phong
exponent, vct_math.glossy_half_angle); interreflection adds what the same cones gather, through the paper's
reflectance. Cones read texels nearest (mip-linear), combine the axes' optical depths weighted by |d_a|
(vct_math.step_transmittance: Beer-Lambert per step, so the step length does not change a medium's
transmittance, and a layer crossed at any angle keeps its optical depth) and keep the smaller transmittance of
that and the finer level's whose texel is the step, read from the column texture (the texel's most covered
column, split into up to four reads two levels finer: vct_trace.glsl derives both; no leak through a one-voxel
wall). A sample's radiance is its faces' rgb over the opacity of those that can carry light toward the cone: a
face black where the other way is lit is a surface's back on that axis, opaque but not counted (vct_front).
A face adds light only where its stored normal faces the cone (m . d < 0: a plane oblique to the grid, seen
from behind, shows no light on a minor axis). A texel that shows the cone a two-sided wall's dark side (the sign
of n.d, read from which face of each axis is lit and which black face holds a normal, a surface facing the
cone on that axis, weighted by |d_a| alpha_a: exact for one wall in a level-0 voxel) adds its opacity and no light
(vct_axis_facing): inside a closed box, the far walls' lit outer sides in a coarse texel stay hidden.
An axis's coverage blocks the cone only where a surface covering that axis faces it (the mean normal of the
axis's face against d or along d has n . d < 0: vct_facing_axes): a ray from outside a closed solid meets a
front before any back, and a coarse texel's surfaces behind the sample, which the cone moves away from, no
longer block it; the finer read keeps every surface's coverage.
The cones start NORMAL_OFFSET_VOXELS
along the normal and START_OFFSET_VOXELS along the cone (in voxels of the finest cascade holding the point):
the self-intersection offset, with the footprint cap (vct_trace.glsl, vct_math.sample_lod): a sample reads the
level its cone's diameter gives, but never one whose lookup reaches the voxels of the surface it leaves
(derived for a trilinear lookup: the coarser level's texel at most (height / |n|_1 - h0) / 1.5; the nearest
lookup reaches less far). The cap keeps a plane from reading itself, but it binds for every diffuse cone of 4,
6 or 9, so `diffuse_cones` sets their directions and weights, not their levels; narrower cones (the glossy
one) keep their own width. An occluder on a capped cone's axis reads as filling the whole cone
(tests/realtime/test_vct_gpu.py measures the over-occlusion under a sphere). A wall parallel to a cone does
not block it (its coverage along its own plane is 0). The cones' cost is inside `draw`; E10 reports `trace` as
draw minus the same scene's direct-only draw.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator

import moderngl
import numpy as np

from realtime.engine import limits
from realtime.engine.gpu import EnvironmentFilter, shader_source
from realtime.engine.technique import Frame, Technique, set_uniform
from realtime.techniques.vct import lobe_table, vct_math
from realtime.techniques.vct.lobe_table import LobeTable
from scenes.model import materials

#: the cones' origin moves this many voxels along the surface normal (self-intersection offset)
NORMAL_OFFSET_VOXELS = 1.5
#: and their first sample is this many voxels along the cone from there
START_OFFSET_VOXELS = 1.0
#: faces of a voxel whose mean normals are closer than this cosine share one injection cone set
SAME_NORMAL_COS = 0.95
#: the bounce passes' cones read their radiance from mips >= this inside every cascade (vct_trace.glsl's
#: vct_rgb_lod_min): they gather the previous bounce's radiance, and the same pass overwrites level 0's rgb in
#: each cascade. Their opacity, like the direct pass's, comes from every level: the coverage pass wrote it and
#: each pass rewrites it unchanged, and read from levels >= 1 a level-1 texel near the surface holds the surface's
#: own layer, which then occludes its own cones (cornell-open's indirect energy at 32^3 goes from 0.81 to 0.86 of
#: the path tracer's one bounce with level 0 read), so the direct light a bounce pass re-injected was darker
#: than the direct pass's
INJECT_LOD_MIN = 1.0
#: injection's cones step this many times the shading's (`step`); 2 halves the injection's time on cornell-open but
#: darkens the injected light by a fifth (Beer-Lambert over fewer samples), so it stays 1
INJECT_STEP_FACTOR = 1.0
#: texture units of the six face textures (1, 2, 5 are the environment's, the prefiltered chain's, shadows')
FACE_UNIT0 = 8
#: texture unit of the column texture (after the six faces)
COLUMN_UNIT = FACE_UNIT0 + 6
#: texture unit of the environment's chain, which the injection reads for the glossy lobe (vct_inject.comp)
ENV_UNIT = COLUMN_UNIT + 1
#: image unit the coverage pass writes the column texture through (0..5: the faces)
COLUMN_IMAGE = 6
#: texture units of the six face-normal textures (after the environment's chain)
NORMAL_UNIT0 = ENV_UNIT + 1
#: texture unit of the gloss texture (the deferred glossy read), and the image the injection writes it through
#: (after the faces' 0..5 and the column texture's 6: the eighth, the most some drivers offer a compute shader)
GLOSS_UNIT = NORMAL_UNIT0 + 6
#: texture unit of the broad-lobe table (lobe_table.py), read with the environment's chain
LOBE_UNIT = GLOSS_UNIT + 1
GLOSS_IMAGE = COLUMN_IMAGE + 1
FACE_NAMES = ("px", "nx", "py", "ny", "pz", "nz")
#: six RGBA16F faces, the RGBA16F column texture and six RGBA8 face normals
BYTES_PER_VOXEL = 7 * 8 + 6 * 4
#: the deferred glossy read's RGBA16F gloss texture, six faces a voxel, on top
GLOSS_BYTES_PER_VOXEL = 6 * 8
#: per voxel: count, kd rgb, ks rgb, exponent, f0, Schlick flag, then from FACE_INTS0 6 x (weight, weighted normal xyz)
VOXEL_INTS = 34
FACE_INTS0 = 10
TRIANGLE_VEC4 = 6  # p0, p1, p2, (normal, two_sided), (kd, f0), (ks, exponent); (schlick, 0, 0, 0) folded below
ALBEDO_SCALE = 4096.0
NORMAL_SCALE = 4096.0
EXPONENT_SCALE = 16.0
#: exponents beyond this are summed as this (int32 sums of 16 N over a voxel's triangles; at N = 4096 the SH9
#: convolution's band factors N / (N + 3) are within 0.1 % of a mirror's 1)
MAX_EXPONENT = 4096.0


def compute_defines(refl: list, triangle_count: int) -> tuple[str, ...]:
    """The voxeliser's and injection's defines, the fixed-point scales of the int32 sums lowered where this
    scene's triangles, all in one voxel, could overflow them (vct_math.sum_scale): per triangle a sum adds at
    most the largest albedo (kd, ks, f0 and the Schlick flag), 1 (a face's normal weight and weighted normal) or
    the largest exponent, each times its scale. `refl`: each object's reflectance_of."""
    albedo = max([1.0] + [float(max(np.max(kd), np.max(ks))) for kd, ks, *_ in refl])
    exponent = max(float(e) for _, _, e, *_ in refl) if refl else 0.0
    return (f"VOXEL_INTS {VOXEL_INTS}", f"FACE_INTS0 {FACE_INTS0}", f"SAME_NORMAL_COS {SAME_NORMAL_COS!r}",
            f"ALBEDO_SCALE {vct_math.sum_scale(ALBEDO_SCALE, triangle_count, albedo)!r}",
            f"NORMAL_SCALE {vct_math.sum_scale(NORMAL_SCALE, triangle_count, 1.0)!r}",
            f"EXPONENT_SCALE {vct_math.sum_scale(EXPONENT_SCALE, triangle_count, exponent)!r}")


def has_glossy(refl: list) -> bool:
    """Whether some object's reflectance has a glossy term the injection traces (ks > 0 and F > 0 somewhere:
    f0 > 0 or Schlick's); `refl`: each object's reflectance_of."""
    return any(np.any(np.asarray(ks) > 0.0) and (f0 > 0.0 or schlick > 0.0) for _, ks, _, f0, schlick in refl)


def reflectance_of(material) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    """(kd, ks, Phong exponent, f0, schlick) of the paper's reflectance as the injection evaluates it
    (vct_inject.comp): L = (1 - F) kd / pi E + F ks L_glossy, F = f0 + schlick (1 - f0) (1 - n.v)^5.
    diffuse: F = 0; phong: F = 1; blend: Schlick's F. glTF's pbr material re-emits as a diffuse surface of
    albedo base_color (its lobe is not the Phong lobe the injection's SH convolution knows)."""
    kind = materials.of(material).name
    kd, ks = np.asarray(material.kd, dtype=np.float64), np.asarray(material.ks, dtype=np.float64)
    exponent = min(float(material.exponent), MAX_EXPONENT)
    if kind == "diffuse":
        return kd, np.zeros(3), exponent, 0.0, 0.0
    if kind == "phong":
        return np.zeros(3), ks, exponent, 1.0, 0.0
    if kind == "blend":
        return kd, ks, exponent, float(material.f0), 1.0
    return np.asarray(material.base_color, dtype=np.float64), np.zeros(3), exponent, 0.0, 0.0


def triangle_records(objects) -> np.ndarray:
    """(T * 6, 4) float32: per triangle p0, p1, p2, (mean vertex normal, two_sided), (kd, f0), (ks, exponent);
    the Schlick flag rides in two_sided's sign bit of information: two_sided + 2 schlick."""
    out = []
    for obj in objects:
        mesh = obj.mesh
        p = mesh.positions.astype(np.float64)
        n = mesh.normals.astype(np.float64)
        idx = mesh.indices.astype(np.int64)
        tri = p[idx]  # (T, 3, 3)
        nn = n[idx].sum(axis=1)
        face = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        length = np.linalg.norm(nn, axis=1, keepdims=True)
        nn = np.where(length > 1e-12, nn / np.maximum(length, 1e-12),
                      face / np.maximum(np.linalg.norm(face, axis=1, keepdims=True), 1e-30))
        rec = np.zeros((len(idx), TRIANGLE_VEC4, 4))
        kd, ks, exponent, f0, schlick = reflectance_of(obj.material)
        rec[:, :3, :3] = tri
        rec[:, 3, :3] = nn
        rec[:, 3, 3] = float(bool(obj.material.two_sided)) + 2.0 * schlick
        rec[:, 4, :3], rec[:, 4, 3] = kd, f0
        rec[:, 5, :3], rec[:, 5, 3] = ks, exponent
        out.append(rec.reshape(-1, 4))
    return np.concatenate(out).astype("f4")


def scene_bounds(objects) -> tuple[np.ndarray, np.ndarray]:
    pts = np.concatenate([o.mesh.positions.astype(np.float64) for o in objects])
    return pts.min(axis=0), pts.max(axis=0)


def groups(n: int, local: int) -> int:
    return (n + local - 1) // local


def sums_split(resolution: int) -> int:
    """The voxels the first of a cascade's two sum buffers holds (vct_voxel_sums.glsl): half of them, so that
    neither buffer passes 2^31 bytes at resolution 256 (1.14 GB each; one would be 2.28 GB)."""
    return resolution ** 3 // 2


class VoxelScene:
    """The scene's voxel cascades on the GPU: voxelised, injected and mipmapped once per frame."""

    def __init__(self, ctx: moderngl.Context, objects, resolution: int, cascades: int, diffuse_cones: int,
                 step: float, bounces: int = 1, grid: vct_math.Cascades | None = None, env_filter=None,
                 deferred_glossy: bool | None = None, radiance: bool = True) -> None:
        """`bounces`: injections per frame (1: direct light; k: k - 1 gathered bounces re-injected);
        `grid`: the cascades (default: centred on the objects' bounding box, vct_math.cascades_for);
        `env_filter`: the frame's environment store, from which the glossy reads take the lobe (its broad-lobe
        table on a cube store, lobe_table.py, and its chain; None: the SH9 radiance, vct_inject.comp);
        `deferred_glossy`: the cones evaluate the glossy surfaces' environment term toward themselves
        (vct_trace.glsl's vct_gloss_radiance) instead of reading it as the faces stored it toward their axes;
        None: wherever some surface is glossy and the environment store is given (it needs the store's chain);
        `radiance`: whether some cone reads the voxels' radiance (interreflection). Occlusion alone reads their
        opacities only, which the occupancy pass writes (vct_inject.comp, inject = 0) and the injection's light
        passes leave as they are: without `radiance` those passes, the environment's reads behind them (the
        weighted chain, the broad-lobe table) and their SH9 projection are not run."""
        self.ctx = ctx
        self.radiance = radiance
        self.resolution, self.count, self.step, self.bounces = resolution, cascades, float(step), bounces
        lo, hi = scene_bounds(objects)
        self.grid = grid or vct_math.cascades_for(lo, hi, resolution, cascades)
        self.cones = vct_math.cone_set(diffuse_cones)
        records = triangle_records(objects)
        self.triangle_count = len(records) // TRIANGLE_VEC4
        size = (resolution, resolution, resolution * cascades)
        limits.check_storage(ctx, records.nbytes, "objects", "the voxelizer's triangle list")
        limits.check_groups(ctx, (groups(self.triangle_count, 64),), "objects", "the voxelizer's dispatch")
        split = sums_split(resolution)
        limits.check_storage(ctx, max(split, resolution ** 3 - split) * VOXEL_INTS * 4, "realtime.vct.resolution",
                             "half a cascade's voxelization scratch")
        limits.check_texture(ctx, "3d", size, "realtime.vct.resolution and realtime.vct.cascades",
                             "the voxel cascades")
        limits.check_groups(ctx, (groups(resolution, 4),) * 2 + (groups(resolution * cascades, 4),),
                            "realtime.vct.resolution and realtime.vct.cascades", "the voxel mip dispatch")
        self.triangles = ctx.buffer(records.tobytes())
        # per cascade, the voxeliser's sums in two buffers: voxels [0, split) and the rest (vct_voxel_sums.glsl)
        self.scratch = [(ctx.buffer(reserve=split * VOXEL_INTS * 4),
                         ctx.buffer(reserve=(resolution ** 3 - split) * VOXEL_INTS * 4)) for _ in range(cascades)]
        self.faces = []
        for _ in range(6):
            tex = ctx.texture3d(size, 4, dtype="f2")
            tex.build_mipmaps()  # allocates the chain; vct_mip.comp writes it
            tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
            tex.repeat_x = tex.repeat_y = tex.repeat_z = False
            self.faces.append(tex)
        self.columns = ctx.texture3d(size, 4, dtype="f2")
        self.columns.build_mipmaps()
        self.columns.filter = (moderngl.NEAREST_MIPMAP_NEAREST, moderngl.NEAREST)
        self.normals = []
        for _ in range(6):
            tex = ctx.texture3d(size, 4, dtype="f1")  # RGBA8: 128 + 127 n, sqrt(1 - l) (vct_normal_bytes.glsl)
            tex.build_mipmaps()
            tex.filter = (moderngl.NEAREST_MIPMAP_NEAREST, moderngl.NEAREST)
            tex.repeat_x = tex.repeat_y = tex.repeat_z = False
            self.normals.append(tex)
        self.mip_levels = self.grid.levels
        here = __package__
        refl = [reflectance_of(o.material) for o in objects]
        #: whether a shader reads the environment's chain: only a glossy surface's lobe does, in the light passes
        self.reads_environment = radiance and env_filter is not None and has_glossy(refl)
        if deferred_glossy is None:
            deferred_glossy = self.reads_environment
        if deferred_glossy and env_filter is None:
            raise ValueError("the deferred glossy read needs the frame's environment store (env_filter)")
        if deferred_glossy and not radiance:
            raise ValueError("the deferred glossy read is a read of the voxels' radiance (radiance is off)")
        self.gloss = None  # the deferred glossy read's texture (deferred_glossy: whether there is one)
        if deferred_glossy:
            # the six faces side by side along x, face f at x in [f R_L, (f + 1) R_L) of every level L
            gloss_size = (6 * resolution, resolution, resolution * cascades)
            limits.check_texture(ctx, "3d", gloss_size, "realtime.vct.resolution and realtime.vct.cascades",
                                 "the deferred glossy read's gloss texture")
            self.gloss = ctx.texture3d(gloss_size, 4, dtype="f2")
            self.gloss.build_mipmaps()  # allocates the chain; vct_mip.comp (VCT_MIP_GLOSS) writes it
            self.gloss.filter = (moderngl.NEAREST_MIPMAP_NEAREST, moderngl.NEAREST)
            self.gloss.repeat_x = self.gloss.repeat_y = self.gloss.repeat_z = False
        defines = compute_defines(refl, self.triangle_count)
        self.voxelize_prog = ctx.compute_shader(shader_source("vct_voxelize.comp", defines, package=here))
        self.env_filter = env_filter
        #: the broad lobes' table (lobe_table.py), on a cube store where a glossy surface reads the environment
        self.lobe_table = (LobeTable(ctx, env_filter)
                           if self.reads_environment and isinstance(env_filter, EnvironmentFilter) else None)
        self.env_defines = () if env_filter is None else (
            "VCT_GLOSSY_ENV", *env_filter.lookup_defines(), *(lobe_table.defines() if self.lobe_table else ()))
        env_defines = self.env_defines
        #: what every program that reads the cones' radiance (vct_trace.glsl) is compiled with: the shading pass's
        #: too. The injection's direct pass uses the cones' opacities only, so its program stores the gloss
        #: (VCT_DEFERRED_GLOSSY) without reading it (VCT_GLOSS_READ): llvmpipe runs both sides of a branch masked,
        #: and a uniform switch cost the direct pass the read's time all the same
        self.trace_defines = ("VCT_DEFERRED_GLOSSY", "VCT_GLOSS_READ", *env_defines) if self.deferred_glossy else ()
        store = ("VCT_DEFERRED_GLOSSY",) if self.deferred_glossy else ()
        self.inject_prog = ctx.compute_shader(shader_source("vct_inject.comp", defines + env_defines + store,
                                                            package=here))
        self._bounce_source = shader_source("vct_inject.comp", defines + env_defines + self.trace_defines,
                                            package=here)
        self.bounce_prog = None  # the bounce passes' program, compiled when first needed (bounce_program)
        self.normals_prog = ctx.compute_shader(shader_source("vct_normals.comp", defines, package=here))
        self.mip_prog = ctx.compute_shader(shader_source("vct_mip.comp", package=__package__))
        self.gloss_mip_prog = (ctx.compute_shader(shader_source("vct_mip.comp", ("VCT_MIP_GLOSS",), package=here))
                               if self.deferred_glossy else None)
        self.normal_mip_prog = ctx.compute_shader(shader_source("vct_normal_mip.comp", package=__package__))
        self.column_mip_prog = ctx.compute_shader(shader_source("vct_column_mip.comp", package=__package__))
        # the faces store radiance times this (vct_math.radiance_scale): the environment's brightest radiance
        # (without the frame's environment store, as in some tests, its SH9 stands in and nothing is scaled)
        peak = 0.0 if env_filter is None else float(np.max(env_filter.radiance)) * max(
            float(np.max(kd) + np.max(ks)) for kd, ks, *_ in refl)
        self.radiance_scale = vct_math.radiance_scale(peak * bounces)
        self.probe_prog = None
        self.cone_prog = None
        self.env_probe_progs: dict[tuple[str, ...], moderngl.ComputeShader] = {}
        self.updated_frame: int | None = None
        self.split: dict[str, float] = {}

    # -- per frame ------------------------------------------------------------------------------
    def _finish_ms(self, t0: float) -> float:
        self.ctx.finish()
        return (time.perf_counter() - t0) * 1e3

    def update(self, frame: Frame | None, sh_buffer: moderngl.Buffer) -> None:
        """Voxelise, inject and mipmap (once per frame number; `frame` None: always); without `radiance` the
        occupancy pass and the mips of its opacities only."""
        if frame is not None and self.updated_frame == frame.number:
            return
        self.updated_frame = None if frame is None else frame.number
        ctx = self.ctx
        mip_ms = 0.0
        R = self.resolution
        if self.reads_environment and isinstance(self.env_filter, EnvironmentFilter):
            # the chain the glossy reads take, refreshed here (counted in `voxelize`) rather than inside a bind
            self.env_filter.solid_angle_chain()
        if self.lobe_table is not None:
            self.lobe_table.build()
        self.voxelize()
        for c in range(self.count):
            self.write_normals(c)
            self.inject(c, 0, sh_buffer)
        ctx.finish()  # the mips' time starts once the work queued before them is done
        t0 = time.perf_counter()
        self.build_mips()
        mip_ms += self._finish_ms(t0)
        light_passes = self.bounces if self.radiance else 0
        for bounce in range(1, light_passes + 1):
            for c in range(self.count):
                self.inject(c, 1 if bounce == 1 else 2, sh_buffer)
            ctx.finish()
            t0 = time.perf_counter()
            self.build_mips(normals=False, gloss=bounce == 1)
            mip_ms += self._finish_ms(t0)
        del R
        ctx.memory_barrier()
        self.split = {"mip": mip_ms}

    def voxelize(self) -> None:
        p = self.voxelize_prog
        self.triangles.bind_to_storage_buffer(0)
        p["triangle_count"] = self.triangle_count
        p["resolution"] = self.resolution
        for c in range(self.count):
            he = self.grid.half_extent_of(c)
            for buffer in self.scratch[c]:
                buffer.clear()
            self.bind_scratch(p, c)
            p["grid_min"] = tuple(float(x - he) for x in self.grid.centre)
            p["voxel"] = 2.0 * he / self.resolution
            p.run(groups(self.triangle_count, 64))
            self.ctx.memory_barrier()

    def bind_scratch(self, prog: moderngl.ComputeShader, cascade: int) -> None:
        """One cascade's voxeliser sums, both buffers, for `prog` (vct_voxel_sums.glsl)."""
        low, high = self.scratch[cascade]
        low.bind_to_storage_buffer(1)
        high.bind_to_storage_buffer(3)
        prog["vct_sums_split"] = sums_split(self.resolution)

    def write_normals(self, cascade: int) -> None:
        """Level 0 of the six face-normal textures of one cascade (vct_normals.comp)."""
        p = self.normals_prog
        self.bind_scratch(p, cascade)
        for f, tex in enumerate(self.normals):
            tex.bind_to_image(f, read=False, write=True, level=0)
        p["cascade"] = cascade
        p["resolution"] = self.resolution
        g = groups(self.resolution, 4)
        p.run(g, g, g)
        self.ctx.memory_barrier()

    @property
    def deferred_glossy(self) -> bool:
        """Whether the cones evaluate the glossy surfaces' environment term toward themselves (a gloss texture)."""
        return self.gloss is not None

    def bounce_program(self) -> moderngl.ComputeShader:
        """The injection's program for the bounce passes, which read the cones' radiance (VCT_GLOSS_READ)."""
        if not self.deferred_glossy:
            return self.inject_prog
        if self.bounce_prog is None:
            self.bounce_prog = self.ctx.compute_shader(self._bounce_source)
        return self.bounce_prog

    def inject(self, cascade: int, mode: int, sh_buffer: moderngl.Buffer) -> None:
        p = self.bounce_program() if mode == 2 else self.inject_prog
        self.bind_trace(p, step=self.step * INJECT_STEP_FACTOR)
        self.bind_scratch(p, cascade)
        sh_buffer.bind_to_storage_buffer(2)
        for f, tex in enumerate(self.faces):
            tex.bind_to_image(f, read=False, write=True, level=0)
        if mode == 0:
            self.columns.bind_to_image(COLUMN_IMAGE, read=False, write=True, level=0)
        if self.gloss is not None:  # written by the coverage and direct passes, read by the bounce passes
            self.gloss.bind_to_image(GLOSS_IMAGE, read=False, write=True, level=0)
        p["cascade"] = cascade
        p["inject"] = mode
        set_uniform(p, "lod_min", 0.0)
        set_uniform(p, "vct_rgb_lod_min", 0.0 if mode == 1 else INJECT_LOD_MIN)
        g = groups(self.resolution, 4)
        p.run(g, g, g)
        self.ctx.memory_barrier()

    def build_mips(self, normals: bool = True, gloss: bool = False) -> None:
        """The six faces' anisotropic mips, the column texture's, (`normals`) the face normals' and (`gloss`) the
        gloss textures'. The normals depend on the geometry only (their level 0 and the faces' opacities), the
        gloss on the opacities and the direct pass, so a bounce pass leaves both."""
        self.build_column_mips()
        p = self.mip_prog
        for level, r in self._levels(p):
            for f, tex in enumerate(self.faces):
                tex.bind_to_image(0, read=True, write=False, level=level - 1)
                tex.bind_to_image(1, read=False, write=True, level=level)
                self.faces[f ^ 1].bind_to_image(2, read=True, write=False, level=level - 1)  # the opposite face
                self._run_face_mip(p, f, r)
        if normals:
            self.build_normal_mips()
        if gloss and self.deferred_glossy:
            self.build_gloss_mips()

    def _levels(self, p: moderngl.ComputeShader) -> Iterator[tuple[int, int]]:
        """Each mip level after the first, as (level, its edge r), with `p`'s dst_size set; a barrier after each,
        so that the next level reads what this one wrote."""
        for level in range(1, self.mip_levels):
            r = self.resolution >> level
            p["dst_size"] = (r, r, r * self.count)
            yield level, r
            self.ctx.memory_barrier()

    def _run_face_mip(self, p: moderngl.ComputeShader, f: int, r: int) -> None:
        """One mip level (edge r) of face f's direction through a program whose images are bound."""
        p["axis"] = f // 2
        p["sign_"] = 1 if f % 2 == 0 else -1
        p.run(groups(r, 4), groups(r, 4), groups(r * self.count, 4))

    def build_gloss_mips(self) -> None:
        """The gloss texture's mips (vct_mip.comp's VCT_MIP_GLOSS), composited with the faces' opacities."""
        p = self.gloss_mip_prog
        for level, r in self._levels(p):
            self.gloss.bind_to_image(0, read=True, write=False, level=level - 1)
            self.gloss.bind_to_image(1, read=False, write=True, level=level)
            for f in range(6):
                p["face"] = f
                self.faces[f].bind_to_image(3, read=True, write=False, level=level - 1)
                self.faces[f ^ 1].bind_to_image(4, read=True, write=False, level=level - 1)
                self._run_face_mip(p, f, r)

    def build_normal_mips(self) -> None:
        """The face normals' mips (vct_normal_mip.comp), weighted by the faces' opacities: after theirs."""
        p = self.normal_mip_prog
        for level, r in self._levels(p):
            for f, tex in enumerate(self.normals):
                tex.bind_to_image(0, read=True, write=False, level=level - 1)
                tex.bind_to_image(1, read=False, write=True, level=level)
                self.faces[f].bind_to_image(2, read=True, write=False, level=level - 1)
                self._run_face_mip(p, f, r)

    def build_column_mips(self) -> None:
        p = self.column_mip_prog
        for level, r in self._levels(p):
            self.columns.bind_to_image(0, read=True, write=False, level=level - 1)
            self.columns.bind_to_image(1, read=False, write=True, level=level)
            p.run(groups(r, 4), groups(r, 4), groups(r * self.count, 4))

    # -- tracing uniforms -----------------------------------------------------------------------
    def bind_trace(self, prog: moderngl.Program, step: float | None = None) -> None:
        """The voxels and the cones' uniforms for a program that includes vct_trace.glsl; `step` (default the
        table's) sets the cones' step and the loop bound that follows from it."""
        step = self.step if step is None else step
        for f, tex in enumerate(self.faces):
            tex.use(FACE_UNIT0 + f)
            set_uniform(prog, f"vct_face_{FACE_NAMES[f]}", FACE_UNIT0 + f)
        for f, tex in enumerate(self.normals):
            tex.use(NORMAL_UNIT0 + f)
            set_uniform(prog, f"vct_normal_{FACE_NAMES[f]}", NORMAL_UNIT0 + f)
        self.columns.use(COLUMN_UNIT)
        set_uniform(prog, "vct_columns", COLUMN_UNIT)
        if self.deferred_glossy:
            self.gloss.use(GLOSS_UNIT)
            set_uniform(prog, "vct_gloss", GLOSS_UNIT)
        if self.env_filter is not None:
            self.bind_environment(prog)
        g = self.grid
        set_uniform(prog, "vct_centre", g.centre)
        set_uniform(prog, "vct_half_extent", g.half_extent)
        set_uniform(prog, "vct_voxel", g.voxel_size)
        set_uniform(prog, "vct_resolution", g.resolution)
        set_uniform(prog, "vct_cascades", g.count)
        set_uniform(prog, "vct_step", step)
        set_uniform(prog, "vct_max_samples", vct_math.max_cone_samples(g.resolution, g.count, step))
        set_uniform(prog, "vct_start_voxels", START_OFFSET_VOXELS)
        set_uniform(prog, "vct_normal_voxels", NORMAL_OFFSET_VOXELS)
        set_uniform(prog, "vct_radiance_scale", self.radiance_scale)
        set_uniform(prog, "vct_rgb_lod_min", 0.0)
        cones = self.cones
        dirs = np.zeros((9, 3), "f4")
        dirs[: len(cones.directions)] = cones.directions
        weights = np.zeros(9, "f4")
        weights[: len(cones.weights)] = cones.weights
        set_uniform(prog, "vct_cone_count", len(cones.directions))
        if "vct_cone_dir" in prog:
            prog["vct_cone_dir"].write(dirs.tobytes())
        if "vct_cone_weight" in prog:
            prog["vct_cone_weight"].write(weights.tobytes())
        set_uniform(prog, "vct_cone_tan", math.tan(cones.half_angle))

    def bind_environment(self, prog, unit: int = ENV_UNIT) -> None:
        """What vct_glossy_env.glsl reads (the injection's glossy lobe, the deferred glossy read): on `unit` the
        environment's chain, on the cube the chain weighted by solid angle (EnvironmentFilter.solid_angle_chain;
        the read divides rgb by a), where the paper's box chain misses a face's mean radiance at its coarse
        levels, and on LOBE_UNIT the broad-lobe table (lobe_table.py) the lobes below N = 255 come from; a 2D
        store's own chain (env_map.glsl). A scene without a glossy surface, or whose voxels hold no light
        (occlusion alone), reads none: the paper's cube is bound to the sampler as it stands, and neither the
        weighted chain nor the table is built. Both are refreshed here if the store was filled since (normally
        done at the start of `update`)."""
        if isinstance(self.env_filter, EnvironmentFilter) and self.reads_environment:
            self.env_filter.solid_angle_chain().use(unit)
            set_uniform(prog, "vct_env_cube", unit)
            if self.lobe_table is not None:
                self.lobe_table.build()
                self.lobe_table.bind(prog, LOBE_UNIT)
        else:
            self.env_filter.bind_lookup(prog, unit, cube_uniform="vct_env_cube")
        set_uniform(prog, "vct_env_base_size", float(self.env_filter.base_size))

    # -- read-backs (tests, measurements) -------------------------------------------------------
    def occupied(self, cascade: int = 0) -> np.ndarray:
        """(R, R, R) bool indexed [x, y, z]: voxels some triangle touched."""
        acc = np.frombuffer(b"".join(b.read() for b in self.scratch[cascade]), dtype="i4").reshape(
            self.resolution, self.resolution, self.resolution, VOXEL_INTS)
        return acc[..., 0].transpose(2, 1, 0) > 0

    def read_faces(self, level: int = 0) -> np.ndarray:
        """(6, C, R_L, R_L, R_L, 4) float32 indexed [face, cascade, x, y, z, rgba] of one mip level."""
        return self._read_textures(self.faces, level)

    def read_gloss(self, level: int = 0) -> np.ndarray:
        """The deferred glossy read's gloss texture, as read_faces: rgb the lobe's weight F ks V_g, a its mean times
        the exponent, both premultiplied by the coverage."""
        if not self.deferred_glossy:
            raise ValueError("this voxel scene stores no gloss texture (deferred_glossy is off)")
        side_by_side = self._read_textures([self.gloss], level, width=6)[0]  # (C, 6 R_L, R_L, R_L, 4)
        return np.stack(np.split(side_by_side, 6, axis=1))

    def read_columns(self, level: int = 0) -> np.ndarray:
        """(C, R_L, R_L, R_L, 3) float32 indexed [cascade, x, y, z, axis]: the column texture at one mip level."""
        return self._read_textures([self.columns], level)[0, ..., :3]

    def read_normals(self, level: int = 0) -> np.ndarray:
        """(6, C, R_L, R_L, R_L, 3) float32 indexed [face, cascade, x, y, z, xyz]: the face normals at one mip
        level (0 where no surface faces the face's direction)."""
        v = self._read_textures(self.normals, level, rgba8=True)
        return ((255.0 * v[..., :3] - 128.0) / 127.0).astype("f4")  # vct_normal_bytes.glsl

    def read_normal_mean_lengths(self, level: int = 0) -> np.ndarray:
        """(6, C, R_L, R_L, R_L) float32: the mean cosine l, about each face normal, of the unit normals it stands
        for (1 for one plane; vct_normal_bytes.glsl stores sqrt(1 - l) in alpha)."""
        a = self._read_textures(self.normals, level, rgba8=True)[..., 3]
        return (1.0 - a * a).astype("f4")

    def _read_textures(self, textures, level: int, rgba8: bool = False, width: int = 1) -> np.ndarray:
        """(T, C, width R_L, R_L, R_L, 4) indexed [texture, cascade, x, y, z, rgba] (`width`: textures that many
        cascades wide along x, as the gloss texture's six faces)."""
        r = self.resolution >> level
        prog = self.ctx.compute_shader(shader_source("vct_dump.comp", ("DUMP_RGBA8",) if rgba8 else (),
                                                     package=__package__))
        buf = self.ctx.buffer(reserve=width * r * r * r * self.count * 16)
        out = []
        for tex in textures:
            tex.bind_to_image(0, read=True, write=False, level=level)
            buf.bind_to_storage_buffer(1)
            prog["size"] = (width * r, r, r * self.count)
            prog.run(groups(width * r, 4), groups(r, 4), groups(r * self.count, 4))
            self.ctx.memory_barrier()
            vol = np.frombuffer(buf.read(), dtype="f4").reshape(self.count * r, r, width * r, 4)  # [z, y, x]
            out.append(vol.reshape(self.count, r, r, width * r, 4).transpose(0, 3, 2, 1, 4))
        buf.release()
        prog.release()
        return np.stack(out)

    def write_level0(self, faces: np.ndarray, normals: np.ndarray | None = None,
                     mean_lengths: np.ndarray | None = None) -> None:
        """Tests: level 0 of every face from (6, C, R, R, R, 4) [face, cascade, x, y, z, rgba], and of the face
        normals from (6, C, R, R, R, 3) unit vectors or 0 for none (None: each face's own direction wherever the face is
        opaque, 0 elsewhere: surfaces along the grid's axes, each facing every face that holds it), with the mean
        cosines of the unit normals each stands for (6, C, R, R, R) (None: 1, one plane a face)."""
        for f, tex in enumerate(self.faces):
            vol = faces[f].transpose(0, 3, 2, 1, 4).reshape(-1)  # [c, z, y, x]
            tex.write(np.ascontiguousarray(vol, dtype="f2").tobytes())
        if normals is None:
            normals = np.where(faces[..., 3:4] > 0.0, np.asarray(vct_math.FACES, "f4")[:, None, None, None, None],
                               0.0)
        for f, tex in enumerate(self.normals):  # the bytes of vct_normal_bytes.glsl
            stored = np.zeros(normals.shape[1:-1] + (4,), np.uint8)
            stored[..., :3] = np.round(128.0 + 127.0 * np.clip(normals[f], -1.0, 1.0))
            if mean_lengths is not None:
                stored[..., 3] = np.round(255.0 * np.sqrt(np.clip(1.0 - mean_lengths[f], 0.0, 1.0)))
            tex.write(np.ascontiguousarray(stored.transpose(0, 3, 2, 1, 4).reshape(-1)).tobytes())
        # the column texture along each axis: the larger opacity of its two faces
        occ = np.zeros(faces.shape[1:], "f4")
        occ[..., :3] = np.maximum(faces[0::2, ..., 3], faces[1::2, ..., 3]).transpose(1, 2, 3, 4, 0)
        self.columns.write(np.ascontiguousarray(occ.transpose(0, 3, 2, 1, 4).reshape(-1), dtype="f2").tobytes())

    def probe(self, points: np.ndarray, normals: np.ndarray, lod_min: float = 0.0,
              rgb_lod_min: float = 0.0) -> np.ndarray:
        """The diffuse cones at points with normals: (N, 4) = (gathered irradiance rgb, visibility); `lod_min`
        floors the levels the cones read, `rgb_lod_min` those of their radiance alone (a bounce pass's view:
        INJECT_LOD_MIN)."""
        if self.probe_prog is None:
            self.probe_prog = self.ctx.compute_shader(shader_source("vct_probe.comp", self.trace_defines,
                                                                      package=__package__))
        p = self.probe_prog
        n = len(points)
        data = np.zeros((n, 2, 4), "f4")
        data[:, 0, :3] = points
        data[:, 1, :3] = normals
        return self._dispatch(p, data, "probe points", "the probe's points", lod_min, rgb_lod_min)

    def trace_cone(self, origins: np.ndarray, directions: np.ndarray, tan_half: np.ndarray, t0: np.ndarray,
                   surfaces: np.ndarray, normals: np.ndarray, lod_min: float = 0.0,
                   rgb_lod_min: float = 0.0) -> np.ndarray:
        """Tests: single cones as the shading traces them (vct_trace.glsl's vct_cone): (N, 4) = (radiance
        gathered, occlusion) of the cones from `origins` along `directions` with tan(half-angle) `tan_half`,
        first sample at `t0`, leaving the surface through `surfaces` with `normals`."""
        if self.cone_prog is None:
            self.cone_prog = self.ctx.compute_shader(shader_source("vct_cone.comp", self.trace_defines,
                                                                     package=__package__))
        p = self.cone_prog
        n = len(origins)
        data = np.zeros((n, 4, 4), "f4")
        data[:, 0, :3], data[:, 0, 3] = origins, t0
        data[:, 1, :3], data[:, 1, 3] = directions, tan_half
        data[:, 2, :3], data[:, 3, :3] = surfaces, normals
        return self._dispatch(p, data, "cones", "the cone probe's cones", lod_min, rgb_lod_min)

    def read_environment(self, directions: np.ndarray, exponents: np.ndarray, table: bool = True) -> np.ndarray:
        """Tests: the environment as the glossy reads take it (vct_glossy_env.glsl, bound by `bind_environment`):
        (N, 3) L_g along `directions` (N, 3) for Phong `exponents` (N,); `table` False: the chain alone, as
        without the broad-lobe table (the measure it is checked against)."""
        if self.env_filter is None:
            raise ValueError("reading the environment's chain needs the frame's environment store (env_filter)")
        defines = self.env_defines if table else tuple(d for d in self.env_defines if d not in lobe_table.defines())
        prog = self.env_probe_progs.get(defines)
        if prog is None:
            prog = self.env_probe_progs[defines] = self.ctx.compute_shader(
                shader_source("vct_env_probe.comp", defines, package=__package__))
        data = np.zeros((len(directions), 4), "f4")
        data[:, :3], data[:, 3] = directions, exponents
        return self._dispatch(prog, data, "environment reads", "the environment probe's reads", 0.0)[:, :3]

    def _dispatch(self, prog, data: np.ndarray, key: str, what: str, lod_min: float,
                  rgb_lod_min: float = 0.0) -> np.ndarray:
        """Run a trace-reading compute shader over the records in `data` (storage buffer 0), one
        invocation each, and read back its (N, 4) results (storage buffer 1) as float64."""
        n = len(data)
        limits.check_storage(self.ctx, data.nbytes, key, what)
        src = self.ctx.buffer(data.tobytes())
        out = self.ctx.buffer(reserve=n * 16)
        try:
            self.bind_trace(prog)
            src.bind_to_storage_buffer(0)
            out.bind_to_storage_buffer(1)
            prog["count"] = n
            set_uniform(prog, "lod_min", lod_min)
            set_uniform(prog, "vct_rgb_lod_min", rgb_lod_min)
            prog.run(groups(n, 64))
            self.ctx.memory_barrier()
            return np.frombuffer(out.read(), "f4").reshape(n, 4).astype(np.float64)
        finally:
            src.release()
            out.release()

    def meta(self) -> dict:
        g = self.grid
        per_voxel = BYTES_PER_VOXEL + (GLOSS_BYTES_PER_VOXEL if self.deferred_glossy else 0)
        per = g.bytes_per_cascade(per_voxel)
        return {"vct": {"resolution": g.resolution, "cascades": g.count, "diffuse_cones": len(self.cones.weights),
                        "cone_aperture_deg": 2.0 * math.degrees(self.cones.half_angle), "step": self.step,
                        "normal_offset_voxels": NORMAL_OFFSET_VOXELS, "start_offset_voxels": START_OFFSET_VOXELS,
                        "centre": list(g.centre), "finest_half_extent": g.half_extent,
                        "outer_half_extent": g.half_extent_of(g.count - 1), "voxel_size": g.voxel_size,
                        "bytes_per_voxel": per_voxel, "bytes_per_cascade": [per] * g.count,
                        "bytes": per * g.count, "single_texture_bytes": g.single_texture_bytes(per_voxel),
                        "glossy_read": "deferred" if self.deferred_glossy else "six faces",
                        "single_texture_resolution": g.resolution << (g.count - 1),
                        "scratch_bytes": sum(b.size for pair in self.scratch for b in pair),
                        "triangles": self.triangle_count,
                        "bounces": self.bounces, "radiance_scale": self.radiance_scale,
                        "radiance_injected": self.radiance}}

    def release(self) -> None:
        scratch = [b for pair in self.scratch for b in pair]
        for r in [self.triangles, *scratch, *self.faces, *self.normals, self.gloss, self.columns,
                  self.voxelize_prog, self.normals_prog, self.inject_prog, self.bounce_prog, self.mip_prog,
                  self.gloss_mip_prog, self.normal_mip_prog, self.column_mip_prog,
                  self.probe_prog, self.cone_prog, *self.env_probe_progs.values(), self.lobe_table]:
            if r is not None:
                r.release()


def sh_source(frame: Frame) -> moderngl.Buffer:
    """The buffer with this frame's SH9 matrices M for the injection: the scene's own (diffuse = "sh",
    the paper's order, already projected this frame: its window included), else projected here."""
    rt = frame.scene.realtime
    if not ("diffuse" in frame.scene.effects and rt.diffuse == "sh" and rt.sh_order == 2):
        frame.env_filter.project_sh(frame.face_size)
    return frame.env_filter.sh_buffer


def shared_voxels(frame: Frame) -> VoxelScene:
    if "vct" not in frame.shared:
        rt = frame.scene.realtime
        v = rt.vct
        # occlusion alone reads the cones' opacities only: no light is injected, no glossy read stored
        radiance = rt.interreflection == "vct"
        deferred = None if radiance and v.glossy_read == "deferred" else False
        frame.shared["vct"] = VoxelScene(frame.ctx, frame.scene.objects, v.resolution, v.cascades,
                                         v.diffuse_cones, v.step, bounces=v.bounces, env_filter=frame.env_filter,
                                         deferred_glossy=deferred, radiance=radiance)
    return frame.shared["vct"]


class _VctEffect(Technique):
    """What `occlusion = "vct"` and `interreflection = "vct"` share: the voxel scene, its per-frame update."""

    def __init__(self, frame: Frame) -> None:
        super().__init__(frame)
        self.voxels: VoxelScene | None = None
        self.owner = False
        self._split: dict[str, float] = {}

    def chain_level(self, frame: Frame) -> int | None:
        # the whole chain: on a 2D store the injection's glossy lobe reads its own chain at the lobe's level (on the
        # cube the weighted chain, built apart). Occlusion alone reads none, and has the box chain built all the same
        # (the whole chain takes 1.8 ms at base 256 on llvmpipe)
        return None

    def prepare(self, frame: Frame) -> None:
        self.owner = "vct" not in frame.shared
        self.voxels = shared_voxels(frame)

    def update(self, frame: Frame) -> None:
        before = self.voxels.updated_frame
        # the SH9 the light passes inject by, projected once a frame, by whichever effect updates the voxels first
        project = self.voxels.radiance and before != frame.number
        self.voxels.update(frame, sh_source(frame) if project else frame.env_filter.sh_buffer)
        self._split = dict(self.voxels.split) if before != frame.number else {}

    def split_timings(self) -> dict[str, float]:
        out, self._split = self._split, {}
        return out

    def bind(self, prog: moderngl.Program) -> None:
        self.voxels.bind_trace(prog)

    def trace_defines(self) -> tuple[str, ...]:
        """The voxel scene's own defines for the cones the shading pass traces (the deferred glossy read)."""
        return self.voxels.trace_defines if self.voxels is not None else ()

    def bind_object(self, prog: moderngl.Program, obj) -> None:
        set_uniform(prog, "vct_glossy_tan", math.tan(vct_math.glossy_half_angle(float(obj.material.exponent))))
        set_uniform(prog, "vct_glossy_exponent", float(obj.material.exponent))

    def meta(self) -> dict:
        return self.voxels.meta() if self.owner else {}

    def release(self) -> None:
        if self.owner and self.voxels is not None:
            self.voxels.release()
            self.frame.shared.pop("vct", None)


class VctOcclusion(_VctEffect):
    """`occlusion = "vct"`: the environment's diffuse and glossy light times the cones' visibility."""

    def defines(self) -> tuple[str, ...]:
        return ("VCT_OCCLUSION", *self.trace_defines())


class VctInterreflection(_VctEffect):
    """`interreflection = "vct"`: plus the one-bounce radiance the same cones gather from the voxels."""

    def defines(self) -> tuple[str, ...]:
        return ("VCT_INTERREFLECTION", *self.trace_defines())
