"""The OpenGL half of `realtime.diffuse = "hemisphere"`: the sky and ground radiances, computed once per
scene (sky_ground.py), bound as two uniforms of the shading pass (diffuse_hemisphere.glsl)."""

from __future__ import annotations

import moderngl

from iblcheck_hemisphere.sky_ground import sky_ground
from realtime.engine.technique import NO_CUBE, Frame, Technique, set_uniform


class HemisphereDiffuse(Technique):
    def __init__(self, frame: Frame) -> None:
        super().__init__(frame)
        self.sky = self.ground = (0.0, 0.0, 0.0)

    def chain_level(self, frame: Frame) -> int | None:
        return NO_CUBE  # it reads the equirect map once, never the cube map

    def prepare(self, frame: Frame) -> None:
        sky, ground = sky_ground(frame.scene.environment.radiance())
        g = frame.scene.realtime.hemisphere.ground_scale
        self.sky, self.ground = tuple(float(c) for c in sky), tuple(float(g * c) for c in ground)

    def defines(self) -> tuple[str, ...]:
        return ("DIFFUSE_HEMISPHERE",)

    def bind(self, prog: moderngl.Program) -> None:
        set_uniform(prog, "hemisphere_sky", self.sky)
        set_uniform(prog, "hemisphere_ground", self.ground)

    def meta(self) -> dict:
        return {"hemisphere": {"sky": list(self.sky), "ground": list(self.ground)}}
