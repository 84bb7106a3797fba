"""Glossy technique `prefiltered`: the environment convolved with each material's own Phong lobe,
per frame (`realtime.glossy = "prefiltered"`, `[realtime.prefiltered] samples, bias`).

What Filament's cmgen and Khronos' glTF-IBL-Sampler do for GGX, here for the paper's normalised
Phong lobe (realtime/techniques/prefiltered/prefilter.py): one chain per distinct exponent N in the scene, each texel
the
mean of `samples` lobe-distributed reads of the box chain, with filtered importance sampling
(Krivanek & Colbert 2008) choosing a coarser source level where a sample's pdf is low. The Phong
lobe about the mirror direction r is an exact convolution (no n = v assumption, unlike GGX); like the
paper's box chain it ignores the horizon cut. The shader reads an object's chain at
`levels.prefiltered_lod` (the level that resolves its lobe, never finer than the selected face size),
and only the levels from there down are prefiltered.
"""

from __future__ import annotations

import math

import moderngl

from realtime.engine import levels
from realtime.engine.technique import Frame, Technique, set_uniform
from realtime.techniques.prefiltered.prefilter import PhongPrefilter

PREFILTERED_UNIT = 3


class PrefilteredGlossy(Technique):
    def __init__(self, frame: Frame) -> None:
        super().__init__(frame)
        rt = frame.scene.realtime
        self.params = rt.prefiltered
        exponents = sorted({o.material.exponent for o in frame.scene.objects if o.material.has_glossy})
        self.lods = {n: levels.prefiltered_lod(frame.face_size, rt.base_size, n) for n in exponents}
        self.chains: dict[float, object] = {}

    def chain_level(self, frame: Frame) -> int | None:
        return None  # filtered importance sampling reads coarse levels of the box chain

    def first_level(self, exponent: float) -> int:
        return int(math.floor(self.lods[exponent]))

    def prepare(self, frame: Frame) -> None:
        base = frame.scene.realtime.base_size
        for n in self.lods:
            self.chains[n] = PhongPrefilter(frame.ctx, base, n, self.params.samples, self.params.bias)

    def update(self, frame: Frame) -> None:
        for n, chain in self.chains.items():
            chain.run(frame.env_filter.cube, self.first_level(n))

    def defines(self) -> tuple[str, ...]:
        return ("GLOSSY_PREFILTERED",)

    def bind_object(self, prog: moderngl.Program, obj) -> None:
        n = obj.material.exponent
        if n not in self.chains:  # an object without a glossy lobe: the shader does not read it
            return
        self.chains[n].texture.use(PREFILTERED_UNIT)
        set_uniform(prog, "prefiltered_cube", PREFILTERED_UNIT)
        set_uniform(prog, "prefiltered_lod", self.lods[n])

    def meta(self) -> dict:
        return {"prefiltered": {"samples": self.params.samples, "bias": self.params.bias,
                                "lod": {f"{n:g}": lod for n, lod in self.lods.items()}}}

    def release(self) -> None:
        for chain in self.chains.values():
            chain.release()
