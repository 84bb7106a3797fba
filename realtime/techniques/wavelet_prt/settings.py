"""The settings a scene's wavelet transfer runs with: one function, read by the technique (wavelet_prt.py) and by
whoever precomputes or reports the transfer elsewhere, so the derivation lives once."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class WaveletSettings:
    """What the transfer is computed with (wavelet_transfer.cached_transfer) and the frame selects."""
    cube_size: int  # face side of the lighting's cube level
    terms: int  # K, the lighting coefficients kept per frame
    threshold: float  # the transfer's storage threshold, relative to each vertex's largest coefficient
    rays: int  # hemisphere rays of the bounce gather (0 without bounces: none are traced, the key needs none)
    bounces: int  # interreflected bounces (0 unless realtime.interreflection = "wavelet_prt")
    shadowed: bool  # realtime.occlusion = "wavelet_prt"


def effective_settings(scene) -> WaveletSettings:
    """The wavelet PRT settings of `scene`: [realtime.wavelet_prt] cube_size, terms and threshold always; its
    bounces only with interreflection = "wavelet_prt", and its rays only with bounces (visibility itself is one ray
    per cube texel, no parameter)."""
    rt = scene.realtime
    w = rt.wavelet_prt
    bounces = int(w.bounces) if rt.interreflection == "wavelet_prt" else 0
    return WaveletSettings(cube_size=int(w.cube_size), terms=int(w.terms), threshold=float(w.threshold),
                           rays=int(w.rays) if bounces else 0, bounces=bounces,
                           shadowed=rt.occlusion == "wavelet_prt")
