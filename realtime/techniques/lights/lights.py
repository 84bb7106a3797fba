"""The light array on the GPU: `realtime.diffuse = "lights"` and `realtime.glossy = "lights"`.

The environment is stood in for by N distant lights (scenes/environment/light_array.py: geodesic or median-cut
placement, each light carrying the radiance of its own region of the map, so their powers sum to
the map's integral). Once per scene (`precompute`): the placement and, for every texel of the
equirect map, the light whose region holds it (a texel list per light). Every frame (`lights`): the
powers are re-summed from the map on the GPU (light_power.comp: the map may change from frame to
frame, as the paper's refiltering assumes), and the directions turn with the map
(`rotate_deg_per_frame`). Shading (lights.glsl) sums every light through the paper's reflectance,
times its shadow-map visibility when `realtime.occlusion = "shadow_maps"`
(realtime/techniques/shadow_maps/shadow_maps.py).

Diffuse and glossy share one array (the first of them to run in a frame updates it).
"""

from __future__ import annotations

import moderngl
import numpy as np

from realtime.engine import limits
from realtime.engine.gpu import shader_source
from realtime.engine.technique import NO_CUBE, Frame, Technique, set_uniform
from scenes.environment import light_array
from scenes.environment.directions import equirect_solid_angles, rotation_y

POWER_BINDING, DIRECTION_BINDING = 4, 5


class LightArrayGpu:
    """One scene's light array: the texel regions (uploaded once), powers and directions (per frame)."""

    def __init__(self, ctx: moderngl.Context, env: np.ndarray, placement: str, count: int) -> None:
        self.ctx = ctx
        self.array = light_array.make(env, placement, count)
        h, w = env.shape[:2]
        self.width = w
        limits.check_groups(ctx, (self.array.count,), "realtime.lights.count", "the light power sums")
        limits.check_storage(ctx, h * w * 4, "environment.map", "the light array's texel lists")
        order = np.argsort(self.array.texel_light.ravel(), kind="stable").astype("i4")
        offsets = np.searchsorted(self.array.texel_light.ravel()[order], np.arange(count + 1)).astype("i4")
        self.offsets = ctx.buffer(offsets.tobytes())
        self.texels = ctx.buffer(order.tobytes())
        self.row_omega = ctx.buffer(equirect_solid_angles(h, w)[:, 0].astype("f4").tobytes())
        self.powers = ctx.buffer(reserve=count * 16)
        self.directions = ctx.buffer(reserve=count * 16)
        self.prog = ctx.compute_shader(shader_source("light_power.comp", package=__package__))
        self.updated_frame: int | None = None
        self.world_directions = self.array.directions
        self.map_integral = light_array.map_integral(env)

    @property
    def count(self) -> int:
        return self.array.count

    def update(self, frame: Frame) -> None:
        """Once per frame: powers re-summed from the map on the GPU, directions turned with it."""
        if self.updated_frame == frame.number:
            return
        self.updated_frame = frame.number
        self.world_directions = self.array.directions @ rotation_y(frame.rotation_deg).T  # world = R d_map
        dirs = np.zeros((self.count, 4), "f4")
        dirs[:, :3] = self.world_directions
        self.directions.write(dirs.tobytes())
        frame.env_filter.env_tex.use(0)
        self.prog["env"] = 0
        self.prog["width"] = self.width
        self.offsets.bind_to_storage_buffer(1)
        self.texels.bind_to_storage_buffer(2)
        self.row_omega.bind_to_storage_buffer(3)
        self.powers.bind_to_storage_buffer(4)
        self.prog.run(self.count, 1, 1)
        self.ctx.memory_barrier()

    def read_powers(self) -> np.ndarray:
        """The powers (N, 3) last summed on the GPU."""
        return np.frombuffer(self.powers.read(), "f4").reshape(-1, 4)[:, :3].astype(np.float64)

    def bind(self, prog: moderngl.Program) -> None:
        self.powers.bind_to_storage_buffer(POWER_BINDING)
        self.directions.bind_to_storage_buffer(DIRECTION_BINDING)
        set_uniform(prog, "light_count", self.count)

    def meta(self) -> dict:
        total = self.read_powers().sum(axis=0)
        return {"light_array": {"placement": self.array.placement, "count": self.count,
                                "total_power_gpu": total.tolist(), "map_integral": self.map_integral.tolist()}}

    def release(self) -> None:
        for b in (self.offsets, self.texels, self.row_omega, self.powers, self.directions, self.prog):
            b.release()


def shared_array(frame: Frame) -> LightArrayGpu:
    """The scene's one light array, made by whichever lights technique asks first."""
    if "light_array" not in frame.shared:
        params = frame.scene.realtime.lights
        env = frame.env_filter.radiance  # the map the GPU reads (fitted to the context's limits)
        frame.shared["light_array"] = LightArrayGpu(frame.ctx, env, params.placement, params.count)
    return frame.shared["light_array"]


class _LightsLobe(Technique):
    """What the diffuse and the glossy lobe of the light array share."""

    def __init__(self, frame: Frame) -> None:
        super().__init__(frame)
        self.gpu: LightArrayGpu | None = None
        self.owner = False

    def chain_level(self, frame: Frame) -> int | None:
        return NO_CUBE  # reads the equirect map, not the cube or its chain

    def prepare(self, frame: Frame) -> None:
        self.owner = "light_array" not in frame.shared
        self.gpu = shared_array(frame)

    def update(self, frame: Frame) -> None:
        self.gpu.update(frame)

    def bind(self, prog: moderngl.Program) -> None:
        self.gpu.bind(prog)

    def meta(self) -> dict:
        return self.gpu.meta() if self.owner else {}

    def release(self) -> None:
        if self.owner and self.gpu is not None:
            self.gpu.release()
            self.frame.shared.pop("light_array", None)


class DiffuseLights(_LightsLobe):
    def defines(self) -> tuple[str, ...]:
        return ("DIFFUSE_LIGHTS",)


class GlossyLights(_LightsLobe):
    def defines(self) -> tuple[str, ...]:
        return ("GLOSSY_LIGHTS",)

    def bind_object(self, prog: moderngl.Program, obj) -> None:
        set_uniform(prog, "phong_exponent", float(obj.material.exponent))
