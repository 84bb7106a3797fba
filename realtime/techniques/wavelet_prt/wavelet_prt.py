"""Wavelet precomputed radiance transfer (Ng, Ramamoorthi & Hanrahan 2003, "All-frequency shadows using
non-linear wavelet lighting approximation", SIGGRAPH 2003) for diffuse surfaces: `realtime.diffuse =
"wavelet_prt"`, `occlusion = "wavelet_prt"`, `interreflection = "wavelet_prt"`, `[realtime.wavelet_prt] cube_size,
terms, threshold, rays, bounces`.

Once per scene (`prepare`, cached on disk): every vertex's transfer over the cube texels of face side cube_size,
V(x, w_t) max(0, n . w_t) dOmega_t (plus bounces), Haar-transformed per face and stored sparsely
(wavelet_transfer.py: the storage rule and its bytes; render meta reports `bytes_per_vertex`).
Every frame (timed as `filter`, like PRT's SH projection; wavelet_gpu.py): the environment cube's box level of face
cube_size is Haar-transformed, its `terms` (K) coefficients of largest area-weighted magnitude are kept (haar.py:
the key, the rule for ties), and per vertex E = sum over the K kept of l_j w_v[j] (wavelet_dot.comp: per vertex
the cheaper of K binary searches in its sorted entries and a scan of its entries). The shading pass interpolates
E across the triangle (wavelet_vertex.glsl) and multiplies by kd / pi (irradiance transfer, as PRT's).

With K = 6 cube_size^2 and threshold 0 it is the texel sum of the transfer times the radiance (orthonormal Haar:
nothing is lost). The transfer is the front side's (two-sided materials are refused, as PRT's); only the diffuse
lobe is transferred (`unsimulated_effects` says "glossy occlusion").
"""

from __future__ import annotations

import moderngl

from realtime.engine.technique import NO_CUBE, Frame, Technique
from realtime.engine.transfer_rays import transfer_objects
from realtime.techniques.wavelet_prt.settings import effective_settings
from realtime.techniques.wavelet_prt.wavelet_gpu import WaveletLighting, WaveletObject
from realtime.techniques.wavelet_prt.wavelet_transfer import cached_transfer
from scenes.storage.errors import SceneError

IRRADIANCE_BINDING = 7  # wavelet_vertex.glsl


class WaveletDiffuse(Technique):
    def __init__(self, frame: Frame) -> None:
        super().__init__(frame)
        self.settings = effective_settings(frame.scene)
        self.lighting: WaveletLighting | None = None
        self.objects: list[WaveletObject] = []
        self.info: dict = {}

    def chain_level(self, frame: Frame) -> int | None:
        return None  # the whole box chain (the Haar levels read it from cube_size down to the 2x2 faces)

    def prepare(self, frame: Frame) -> None:
        s = self.settings
        base = frame.env_filter.cube.size[0]
        if s.cube_size > base:
            raise SceneError(f"realtime.wavelet_prt.cube_size = {s.cube_size}: above the environment cube's level-0 "
                             f"face of {base} texels (realtime.base_size)")
        transfers, self.info = cached_transfer(transfer_objects(frame.scene), s.cube_size, s.threshold, s.rays,
                                               s.bounces, s.shadowed, progress=True)
        self.lighting = WaveletLighting(frame.ctx, s.cube_size, s.terms)
        self.objects = [WaveletObject(frame.ctx, t, f"object {i}") for i, t in enumerate(transfers)]

    def update(self, frame: Frame) -> None:
        self.lighting.run(frame.env_filter.cube)
        for o in self.objects:
            o.run(self.lighting)
        frame.ctx.memory_barrier()

    def defines(self) -> tuple[str, ...]:
        return ("DIFFUSE_WAVELET_PRT",)

    def bind_object(self, prog: moderngl.Program, obj) -> None:
        index = next(i for i, o in enumerate(self.frame.scene.objects) if o is obj)
        self.objects[index].irradiance.bind_to_storage_buffer(IRRADIANCE_BINDING)

    def meta(self) -> dict:
        s = self.settings
        return {"wavelet_prt": {"cube_size": s.cube_size, "terms": s.terms, "threshold": s.threshold,
                                "shadowed": s.shadowed, "bounces": s.bounces, "rays": s.rays,
                                **{k: v for k, v in self.info.items() if k != "key"},
                                "cache_key": self.info.get("key")}}

    def release(self) -> None:
        for o in self.objects:
            o.release()
        if self.lighting is not None:
            self.lighting.release()


class WaveletOcclusion(Technique):
    """`occlusion = "wavelet_prt"`: the visibility lives in WaveletDiffuse's transfer; this marks the effect."""

    def chain_level(self, frame: Frame) -> int | None:
        return NO_CUBE  # the transfer is read by WaveletDiffuse, which reads the cube


class WaveletInterreflection(WaveletOcclusion):
    """`interreflection = "wavelet_prt"`: the bounces live in WaveletDiffuse's transfer; this marks the effect."""
