"""Occlusion technique `shadow_maps`: one depth map per light of the array (`realtime.occlusion =
"shadow_maps"`, `[realtime.lights] shadow_map_size`).

The dynamic path: every frame (timed as `shadow`) each light's orthographic depth map of all objects is
redrawn (so moving objects and a turning environment both work), into one depth atlas of
ceil(sqrt(N)) tiles per row. Each map looks along -l_i at the objects' bounding sphere (centre c,
radius R): x, y in [-R, R], depth from c + 2R l_i over [R, 3R]. Shading (shadow_maps.glsl) looks up
light i's tile with percentage-closer filtering (hardware bilinear depth compare at 2x2 taps).

Bias, in units of one shadow texel's world size h = 2R / shadow_map_size (the usual normal-offset
practice: moving the receiver along its normal removes acne on curved receivers without the
peter-panning of a large depth bias): the receiver moves NORMAL_OFFSET_TEXELS h along its normal and
its depth is compared DEPTH_BIAS_TEXELS h closer to the light.

It shadows whatever the array lights: both lobes when `diffuse` and `glossy` are both "lights"; a lobe
lit by another technique (e.g. the paper's box-chain glossy) stays unshadowed and is reported as
"glossy occlusion" in `unsimulated_effects`.
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from realtime.engine import limits
from realtime.engine.gpu import shader_source
from realtime.engine.technique import NO_CUBE, Frame, Technique, set_uniform
from realtime.techniques.lights.lights import shared_array

NORMAL_OFFSET_TEXELS = 1.5
DEPTH_BIAS_TEXELS = 1.0
SHADOW_UNIT, MATRIX_BINDING = 5, 6


def bounding_sphere(scene) -> tuple[np.ndarray, float]:
    """(centre, radius) enclosing every object's vertices (the box's centre, the farthest vertex)."""
    pts = np.concatenate([o.mesh.positions.astype(np.float64) for o in scene.objects])
    centre = (pts.min(axis=0) + pts.max(axis=0)) / 2.0
    return centre, max(float(np.linalg.norm(pts - centre, axis=1).max()), 1e-6)


def light_matrices(directions: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """World -> light clip space (N, 4, 4), row-major: orthographic views along -l_i of the sphere.

    Vectorised over the lights: it runs every frame inside the timed `shadow` key."""
    back = directions / np.linalg.norm(directions, axis=1, keepdims=True)  # the view looks along -z = -l
    helper = np.where(np.abs(back[:, 1:2]) < 0.9, [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    right = np.cross(helper, back)
    right /= np.linalg.norm(right, axis=1, keepdims=True)
    up = np.cross(back, right)
    eye = centre + 2.0 * radius * back
    view = np.zeros((len(back), 4, 4))
    view[:, 0, :3], view[:, 1, :3], view[:, 2, :3] = right, up, back
    view[:, :3, 3] = -np.einsum("nij,nj->ni", view[:, :3, :3], eye)
    view[:, 3, 3] = 1.0
    near, far = radius, 3.0 * radius
    proj = np.array([[1 / radius, 0, 0, 0], [0, 1 / radius, 0, 0],
                     [0, 0, -2 / (far - near), -(far + near) / (far - near)], [0, 0, 0, 1]])
    return proj @ view


class ShadowMaps(Technique):
    def __init__(self, frame: Frame) -> None:
        super().__init__(frame)
        rt = frame.scene.realtime
        self.size = rt.lights.shadow_map_size
        self.count = rt.lights.count
        self.tiles = math.ceil(math.sqrt(self.count))
        self.centre, self.radius = bounding_sphere(frame.scene)
        self.atlas = self.fbo = self.prog = self.matrices = None
        self.vaos: list[moderngl.VertexArray] = []
        self.buffers: list[moderngl.Buffer] = []

    def chain_level(self, frame: Frame) -> int | None:
        return NO_CUBE

    def prepare(self, frame: Frame) -> None:
        ctx = frame.ctx
        side = self.tiles * self.size
        keys = f"realtime.lights.count = {self.count} with realtime.lights.shadow_map_size = {self.size}"
        limits.check_texture(ctx, "2d", (side, side), keys, "the shadow atlas")
        limits.check_texture(ctx, "framebuffer", (side, side), keys, "the shadow atlas")
        limits.check_storage(ctx, self.count * 64, "realtime.lights.count", "the light matrices")
        self.atlas = ctx.depth_texture((side, side))
        self.atlas.compare_func = "<="
        self.atlas.filter = (moderngl.LINEAR, moderngl.LINEAR)  # bilinear PCF of the compare results
        self.atlas.repeat_x = self.atlas.repeat_y = False
        self.fbo = ctx.framebuffer(depth_attachment=self.atlas)
        self.prog = ctx.program(vertex_shader=shader_source("shadow_depth.vert", package=__package__),
                                fragment_shader=shader_source("depth_only.frag", package=__package__))
        self.matrices = ctx.buffer(reserve=self.count * 64)
        for obj in frame.scene.objects:
            vbo = ctx.buffer(obj.mesh.positions.astype("f4").tobytes())
            ibo = ctx.buffer(obj.mesh.indices.astype("i4").tobytes())
            self.buffers += [vbo, ibo]
            self.vaos.append(ctx.vertex_array(self.prog, [(vbo, "3f", "in_position")], index_buffer=ibo))
        self.gpu = shared_array(frame)

    def update(self, frame: Frame) -> None:
        """Every light's depth map, from this frame's light directions."""
        ctx = frame.ctx
        mats = light_matrices(self.gpu.world_directions, self.centre, self.radius)
        self.matrices.write(np.ascontiguousarray(mats.transpose(0, 2, 1), dtype="f4").tobytes())  # column-major
        self.fbo.use()
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)  # open meshes (a plane, the teapot) cast from both sides
        self.fbo.clear(depth=1.0)
        for i, m in enumerate(mats):
            ctx.viewport = ((i % self.tiles) * self.size, (i // self.tiles) * self.size, self.size, self.size)
            self.prog["light_view_proj"].write(np.ascontiguousarray(m.T, dtype="f4").tobytes())
            for vao in self.vaos:
                vao.render(moderngl.TRIANGLES)

    def defines(self) -> tuple[str, ...]:
        return ("OCCLUSION_SHADOW_MAPS",)

    def texel_world_size(self) -> float:
        return 2.0 * self.radius / self.size

    def bind(self, prog: moderngl.Program) -> None:
        self.atlas.use(SHADOW_UNIT)
        self.matrices.bind_to_storage_buffer(MATRIX_BINDING)
        set_uniform(prog, "shadow_atlas", SHADOW_UNIT)
        set_uniform(prog, "shadow_tiles", self.tiles)
        set_uniform(prog, "shadow_size", float(self.size))
        set_uniform(prog, "shadow_normal_offset", NORMAL_OFFSET_TEXELS * self.texel_world_size())
        # depth spans [R, 3R] = 2R over [0, 1]: h world units are h / 2R
        set_uniform(prog, "shadow_depth_bias", DEPTH_BIAS_TEXELS * self.texel_world_size() / (2.0 * self.radius))

    def meta(self) -> dict:
        return {"shadow_maps": {"size": self.size, "lights": self.count, "atlas": self.tiles * self.size,
                                "bytes": 4 * (self.tiles * self.size) ** 2, "texel_world_size": self.texel_world_size(),
                                "normal_offset_texels": NORMAL_OFFSET_TEXELS, "depth_bias_texels": DEPTH_BIAS_TEXELS}}

    def release(self) -> None:
        for r in [*self.vaos, *self.buffers, self.prog, self.fbo, self.atlas, self.matrices]:
            if r is not None:
                r.release()
