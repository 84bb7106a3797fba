"""Glossy technique `split_sum`: Karis' split-sum IBL of glTF's metallic-roughness material with one
engine's recipe (`realtime.glossy = "split_sum"`, `[realtime.split_sum]`, recipes.py).

    L_spec = P(r, roughness) F_ibl(F0, n.v, roughness)

P, the environment prefiltered with the n = v = r GGX lobe, is a chain of cube levels rebuilt every frame
from the environment cube (chain.py: filtered importance sampling of the box chain, timed as `prefilter`),
each level prefiltered at the roughness the recipe's mapping gives it and read between the two levels
around the object's roughness (mappings.py). F_ibl comes from the DFG table (A, B), computed once in
`prepare` (lut.py, timed within `precompute`) at the recipe's size, samples and precision, with the
recipe's multiple-scattering compensation (ibl_fresnel.py). The shading pass composes glTF's mix as the
Khronos viewer does (glossy_split_sum.glsl, split_sum_lobes): the Lambert term base_color / pi E(n) comes
from the scene's diffuse technique.
"""

from __future__ import annotations

import time

import moderngl

from realtime.engine.technique import Frame, Technique, set_uniform
from realtime.techniques.split_sum import mappings, recipes
from realtime.techniques.split_sum.chain import GGXChain
from realtime.techniques.split_sum.ibl_fresnel import MULTISCATTER_CODE
from realtime.techniques.split_sum.lut import DFGTable
from realtime.techniques.split_sum.samples import sample_counts
from scenes.model.materials import PBR_DIELECTRIC_F0

LEVEL_LO_UNIT, LEVEL_HI_UNIT, DFG_UNIT = 3, 4, 6
#: the level from which Filament's cmgen doubles its sample count (cmgen.cpp iblRoughnessPrefilter)
DOUBLE_FROM_LEVEL = 2


class SplitSumGlossy(Technique):
    def __init__(self, frame: Frame) -> None:
        super().__init__(frame)
        self.settings = recipes.resolve(frame.scene.realtime.split_sum)
        s = self.settings
        roughnesses = sorted({o.material.roughness for o in frame.scene.objects if o.material.type == "pbr"})
        self.levels = mappings.chain_levels(s["lod_mapping"], s["size"], s["min_size"], roughnesses)
        self.reads = {r: mappings.read_levels(s["lod_mapping"], r, self.levels, s["size"]) for r in roughnesses}
        self.chain: GGXChain | None = None
        self.table: DFGTable | None = None
        self.lut_ms = 0.0

    def chain_level(self, frame: Frame) -> int | None:
        return None  # filtered importance sampling reads every level of the box chain

    def prepare(self, frame: Frame) -> None:
        s = self.settings
        self.table = DFGTable(frame.ctx, s["lut_size"], s["lut_samples"], s["lut_precision"], s["visibility"])
        frame.ctx.finish()
        t0 = time.perf_counter()
        self.table.compute()
        frame.ctx.finish()
        self.lut_ms = (time.perf_counter() - t0) * 1e3
        counts = sample_counts(len(self.levels), s["samples"], DOUBLE_FROM_LEVEL if s["double_samples"] else None)
        self.chain = GGXChain(frame.ctx, self.levels, frame.env_filter.base_size, counts, s["sampling"],
                              s["fis_bias"])

    def update(self, frame: Frame) -> None:
        self.chain.run(frame.env_filter.cube)

    def defines(self) -> tuple[str, ...]:
        return ("GLOSSY_SPLIT_SUM", f"SPLIT_SUM_MULTISCATTER {MULTISCATTER_CODE[self.settings['multiscatter']]}",
                f"PBR_DIELECTRIC_F0 {PBR_DIELECTRIC_F0!r}")

    def bind(self, prog: moderngl.Program) -> None:
        self.table.texture.use(DFG_UNIT)
        set_uniform(prog, "split_sum_dfg", DFG_UNIT)

    def bind_object(self, prog: moderngl.Program, obj) -> None:
        read = self.reads.get(obj.material.roughness) if obj.material.type == "pbr" else None
        if read is None:  # not a pbr object: the shader does not read the chain
            return
        k0, k1, t = read
        self.chain.textures[k0].use(LEVEL_LO_UNIT)
        self.chain.textures[k1].use(LEVEL_HI_UNIT)
        set_uniform(prog, "split_sum_level_lo", LEVEL_LO_UNIT)
        set_uniform(prog, "split_sum_level_hi", LEVEL_HI_UNIT)
        set_uniform(prog, "split_sum_t", float(t))

    def meta(self) -> dict:
        return {"split_sum": {**self.settings, "levels": [[lv.roughness, lv.size] for lv in self.levels],
                              "reads": {f"{r:g}": list(v) for r, v in self.reads.items()},
                              "lut_ms": self.lut_ms}}

    def release(self) -> None:
        for obj in (self.chain, self.table):
            if obj is not None:
                obj.release()
