"""Glossy technique `box`: the paper's 2x2-box mip chain read at a LOD (`realtime.glossy = "box"`).

L_g = ks textureLod(cube, r, lod) with r the mirror direction and lod = level(s) + offset(N) + bias
(docs/contract.md section 3, step 5). The LOD is computed once per object on the host
(`realtime.engine.levels.glossy_lod`, the only place the formula lives) and passed as a uniform.

On a 2D parameterization (`realtime.parameterization`, realtime/engine/environment_maps.py) the same host
LOD, unclamped, stands for a solid angle (the cube's mean texel at that level); env_map.glsl turns it
into the level whose texel under the lookup covers that solid angle, so `lod_bias` means the same blur.
"""

from __future__ import annotations

import moderngl

from realtime.engine import levels
from realtime.engine.technique import Frame, Technique, set_uniform

ENV_CUBE_UNIT = 1


class BoxGlossy(Technique):
    def chain_level(self, frame: Frame) -> int | None:
        return None  # the LOD may read any level

    def defines(self) -> tuple[str, ...]:
        return ("GLOSSY_BOX", *self.frame.env_filter.lookup_defines())

    def bind(self, prog: moderngl.Program) -> None:
        self.frame.env_filter.bind_lookup(prog, ENV_CUBE_UNIT)

    def lod(self, material) -> float:
        rt = self.frame.scene.realtime
        rule = levels.glossy_lod if rt.parameterization == "cube" else levels.glossy_lod_unclamped
        return rule(self.frame.face_size, rt.base_size, rt.lod_bias, rt.lod_mapping, material.exponent)

    def bind_object(self, prog: moderngl.Program, obj) -> None:
        set_uniform(prog, "glossy_lod", self.lod(obj.material))

    def meta(self) -> dict:
        return {"glossy_lod": [self.lod(o.material) for o in self.frame.scene.objects]}
