"""Precomputed radiance transfer (Sloan, Kautz & Snyder 2002) for diffuse surfaces:
`realtime.diffuse = "prt"`, `occlusion = "prt"`, `interreflection = "prt"`, `[realtime.prt] order, rays, bounces`.

Once per scene (`precompute`, cached on disk): every vertex's transfer vector T
(realtime/techniques/prt/prt_transfer.py,
visibility rays through Embree) of SH `order`, per colour channel:
    unshadowed (diffuse = "prt" alone):   T_k = A_l Y_k(n)                 (exactly SH irradiance)
    shadowed (+ occlusion = "prt"):       the cosine lobe times visibility
    interreflected (+ interreflection):   plus `bounces` diffuse bounces off the other surfaces
Every frame (`filter`, as the paper's SH projection): the environment's SH coefficients of the selected
mip level (sh_project_n.comp, the same projection `diffuse = "sh"` uses, unwindowed); the shading pass
dots them with each vertex's T (shade.vert) and interpolates E across the triangle. All the cost is in
the precomputation; per frame it is a (order + 1)^2 dot product per vertex (orders 2..8: 9..81
coefficients per colour, read from an SSBO by gl_VertexID; `limits.check_storage` warns when an object's
transfer, V x (order + 1)^2 x 3 floats, exceeds the driver's promised block size).

The transfer is the front side's: scenes refuse PRT on two-sided materials (scenes/model/scene.py), and bounces
gather only light leaving front faces, with the object's kd as its albedo (a blend's Fresnel weight
(1 - F) on its diffuse light and its glossy bounces are not in the transfer: "glossy interreflection").
Only the diffuse lobe is transferred: a blend material's glossy term is the paper's (or the prefiltered)
environment lookup, unshadowed, and `unsimulated_effects` says "glossy occlusion".
"""

from __future__ import annotations

import moderngl
import numpy as np

from realtime.engine import limits
from realtime.engine.environment_maps import MapShProjector
from realtime.engine.sh_orders import ShProjector
from realtime.engine.technique import NO_CUBE, Frame, Technique
from realtime.engine.transfer_rays import transfer_objects
from realtime.techniques.prt.prt_transfer import cached_transfer
from realtime.techniques.prt.settings import effective_settings
from scenes.environment import shbasis

TRANSFER_BINDING = 7


class PrtDiffuse(Technique):
    def __init__(self, frame: Frame) -> None:
        super().__init__(frame)
        self.settings = effective_settings(frame.scene)
        self.order = self.settings.order
        self.projector = None
        self.buffers: dict[int, moderngl.Buffer] = {}
        self.info: dict = {}

    def prepare(self, frame: Frame) -> None:
        s = self.settings
        transfers, self.info = cached_transfer(transfer_objects(frame.scene), s.order, s.rays, s.bounces, s.shadowed,
                                               progress=True)
        for i, t in enumerate(transfers):
            data = np.ascontiguousarray(t, dtype="f4")
            limits.check_storage(frame.ctx, data.nbytes, "objects", f"object {i}'s per-vertex transfer")
            self.buffers[i] = frame.ctx.buffer(data.tobytes())
        if frame.scene.realtime.parameterization == "cube":
            self.projector = ShProjector(frame.ctx, self.order)
        else:
            self.projector = MapShProjector(frame.ctx, self.order)

    def update(self, frame: Frame) -> None:
        window = np.ones(self.order + 1)  # the transfer is exact: no deringing window
        if frame.env_filter.parameterization != "cube":
            self.projector.run(frame.env_filter, frame.level, frame.face_size, window)
        else:
            self.projector.run(frame.env_filter.cube, frame.level, frame.face_size, window)

    def defines(self) -> tuple[str, ...]:
        return ("DIFFUSE_PRT", *shbasis.glsl_defines(self.order))

    def bind(self, prog: moderngl.Program) -> None:
        self.projector.buffer.bind_to_storage_buffer(2)

    def bind_object(self, prog: moderngl.Program, obj) -> None:
        index = next(i for i, o in enumerate(self.frame.scene.objects) if o is obj)
        self.buffers[index].bind_to_storage_buffer(TRANSFER_BINDING)

    def meta(self) -> dict:
        s = self.settings
        return {"prt": {"order": s.order, "shadowed": s.shadowed, "bounces": s.bounces,
                        "rays": s.rays_reported, **{k: v for k, v in self.info.items() if k != "key"},
                        "cache_key": self.info.get("key")}}

    def release(self) -> None:
        for b in self.buffers.values():
            b.release()
        if self.projector is not None:
            self.projector.release()


class PrtOcclusion(Technique):
    """`occlusion = "prt"`: the visibility lives in PrtDiffuse's transfer; this marks the effect."""

    def chain_level(self, frame: Frame) -> int | None:
        return NO_CUBE  # the transfer is read by PrtDiffuse, which reads the cube


class PrtInterreflection(PrtOcclusion):
    """`interreflection = "prt"`: the bounces live in PrtDiffuse's transfer; this marks the effect."""
