"""Diffuse technique `irradiance_map`: the exact cosine convolution, per frame, into a cube map read
by normal (`realtime.diffuse = "irradiance_map"`, `[realtime.irradiance_map] size, source_size`).

This is the brute force the paper's SH9 replaces: every texel of the irradiance map sums the whole
source level, E(n) = sum_texels L(w) max(n.w, 0) dOmega(w)
(realtime/techniques/irradiance_map/irradiance_convolution.py), so its only
errors are the source level's resolution and the map's bilinear interpolation. Its cost grows as
size^2 x source_size^2.
"""

from __future__ import annotations

import moderngl

from realtime.engine import levels
from realtime.engine.technique import Frame, Technique, set_uniform
from realtime.techniques.irradiance_map.irradiance_convolution import IrradianceConvolver

IRRADIANCE_UNIT = 2


class IrradianceMapDiffuse(Technique):
    def __init__(self, frame: Frame) -> None:
        super().__init__(frame)
        params = frame.scene.realtime.irradiance_map
        self.size, self.source_size = params.size, params.source_size
        self.source_level = levels.level_of(self.source_size, frame.scene.realtime.base_size)
        self.convolver = None

    def chain_level(self, frame: Frame) -> int | None:
        return self.source_level

    def prepare(self, frame: Frame) -> None:
        self.convolver = IrradianceConvolver(frame.ctx, self.size, self.source_size)

    def update(self, frame: Frame) -> None:
        self.convolver.run(frame.env_filter.cube, self.source_level)

    def defines(self) -> tuple[str, ...]:
        return ("DIFFUSE_IRRADIANCE_MAP",)

    def bind(self, prog: moderngl.Program) -> None:
        self.convolver.texture.use(IRRADIANCE_UNIT)
        set_uniform(prog, "irradiance_cube", IRRADIANCE_UNIT)

    def meta(self) -> dict:
        return {"irradiance_map": {"size": self.size, "source_size": self.source_size,
                                   "source_level": self.source_level}}

    def release(self) -> None:
        if self.convolver is not None:
            self.convolver.release()
