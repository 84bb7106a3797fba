"""`realtime.glossy = "prefiltered"`: the box chain prefiltered with each object's Phong lobe, declared as
data (scenes/model/technique_registry.py); the OpenGL half is glossy_prefiltered.py and prefilter.py."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from scenes.model.technique_registry import Declaration, number, param, require_cube


@dataclass(frozen=True)
class Prefiltered:
    """[realtime.prefiltered]: the Phong-lobe prefiltered chain (prefilter.py)."""
    samples: int = param(64, number(1, 65536, integer=True))  # meets the 50 ms per-frame budget (E7: 16 ... 1024)
    bias: float = param(0.0, number(-16, 16))  # filtered importance sampling: levels added to 0.5 log2(Os / Op)


def validate(rt, given: dict, where: str) -> None:
    if rt.glossy == "prefiltered":
        require_cube(rt, "glossy", where)  # it convolves the cube map


def describe(rt) -> dict:
    return {"prefiltered": asdict(rt.prefiltered)}



def row_label(t) -> str:
    """'prefiltered 64 spl', 'prefiltered 64 spl FIS bias 1'."""
    p = t.get("prefiltered", {})
    return f"prefiltered {p.get('samples')} spl" + (f" FIS bias {p.get('bias'):g}" if p.get("bias") else "")

DECLARATIONS = (
    Declaration(
        effect="glossy", name="prefiltered", rank=20, simulates=frozenset({"glossy"}),
        implementation="realtime.techniques.prefiltered.glossy_prefiltered:PrefilteredGlossy",
        table="prefiltered", parameters=Prefiltered, table_hint='realtime.glossy = "prefiltered"',
        timing_key="prefilter",
        reads=("realtime.prefiltered.",),
        axes={"realtime.prefiltered.samples": (16, 64, 256, 1024)},
        package=__package__, fragment_glsl=("glossy_prefiltered.glsl",),
        validate=validate, describe=describe, row_label=row_label,
    ),
)
