"""`realtime.diffuse = "sh"`: the paper's SH irradiance (order 2: SH9, n^T M n; orders 3 and 4 with a
deringing window), declared as data (scenes/model/technique_registry.py); the OpenGL half is
diffuse_sh.py."""

from __future__ import annotations

from dataclasses import dataclass

from scenes.model.technique_registry import Declaration, combination_error, number, one_of, param


@dataclass(frozen=True)
class ShKeys:
    """The keys SH reads flat in [realtime]."""
    sh_order: int = param(2, number(2, 4, integer=True))  # 2: the paper's SH9; 3, 4: more bands
    sh_window: str = param("none", one_of("none", "hanning", "lanczos", "auto"))  # deringing (deringing.py)


def validate(rt, given: dict, where: str) -> None:
    """The SH knobs set explicitly while another diffuse technique is chosen."""
    if "sh_order" in given and rt.sh_order != 2 and rt.diffuse != "sh":
        raise combination_error(rt, "sh_order", "diffuse", 'the SH order applies to realtime.diffuse = "sh" only',
                                where)
    if "sh_window" in given and rt.sh_window != "none" and rt.diffuse != "sh":
        raise combination_error(rt, "sh_window", "diffuse", 'SH windows apply to realtime.diffuse = "sh" only', where)


def describe(rt) -> dict:
    return {"sh_order": rt.sh_order, "sh_window": rt.sh_window}



def row_label(t) -> str:
    """'SH order 2', 'SH order 4 hanning window'."""
    window = t.get("sh_window")
    return f"SH order {t.get('sh_order')}" + ("" if window == "none" else f" {window} window")

DECLARATIONS = (
    Declaration(
        effect="diffuse", name="sh", rank=10, simulates=frozenset({"diffuse"}),
        implementation="realtime.techniques.sh.diffuse_sh:ShDiffuse",
        flat=ShKeys,
        timing_key="filter",  # the paper's `filter`: cube fill + box chain + SH projection
        reads=("realtime.sh_order", "realtime.sh_window"),
        axes={"realtime.sh_order": (2, 3, 4), "realtime.sh_window": ("none", "auto")},
        package=__package__, fragment_glsl=("diffuse_sh9.glsl", "diffuse_sh_n.glsl"),
        validate=validate, describe=describe, row_label=row_label,
        # E(n) is the material's business: any Lambert term, the paper's kd / pi or glTF's base_color / pi
        materials=frozenset({"diffuse", "blend", "pbr"}),
    ),
)
