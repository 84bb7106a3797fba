"""The settings a scene's precomputed radiance transfer runs with: one function, read by the technique
(prt.py) and by whoever precomputes or reports the transfer elsewhere (a Dask task, the occlusion
experiment), so the derivation lives once."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PrtSettings:
    """What the transfer is computed with (realtime/techniques/prt/prt_transfer.py cached_transfer)."""
    order: int  # SH order of the transfer
    rays: int  # visibility rays per vertex traced (1 when unshadowed: no ray is traced, the key needs one)
    bounces: int  # interreflected bounces (0 unless realtime.interreflection = "prt")
    shadowed: bool  # realtime.occlusion = "prt"

    @property
    def rays_reported(self) -> int:
        """The rays as render metadata reports them: 0 for unshadowed transfer."""
        return self.rays if self.shadowed else 0


def effective_settings(scene) -> PrtSettings:
    """The PRT settings of `scene`: [realtime.prt] order always; its rays only with occlusion = "prt"
    (unshadowed transfer is exact, so it traces none); its bounces only with interreflection = "prt"."""
    rt = scene.realtime
    shadowed = rt.occlusion == "prt"
    return PrtSettings(order=int(rt.prt.order), rays=max(int(rt.prt.rays) if shadowed else 0, 1),
                       bounces=int(rt.prt.bounces) if rt.interreflection == "prt" else 0, shadowed=shadowed)
