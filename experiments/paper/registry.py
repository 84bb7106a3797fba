"""The paper suite's experiments, in number order, and how a name (`E8`, `e08`) finds one.

Every experiment is one module experiments/paper/eNN_<subject>.py of the same shape:

    NUMBER: int                      its number (E<NUMBER>)
    TITLE: str                       the title of its report section
    Settings                         a frozen dataclass of what it varies
    QUICK, FULL: Settings            for `paper --quick` and for the full suite
    count_steps(settings) -> int     how often `run` advances the progress bar
    run(context, settings) -> Section
                                     its rows (through context.row: computed once, reused when found
                                     in results.jsonl) and its report section

`context` (experiments/paper/context.py) carries the output folder, the row runner, the progress
callback, the Dask cluster and the command line's entry points.
"""

from __future__ import annotations

import re
from types import ModuleType

from experiments.paper import (
    e01_diffuse_sh,
    e02_glossy_lod_bias,
    e03_fresnel_blends,
    e04_frame_time,
    e05_reference_convergence,
    e06_stability,
    e07_accuracy_time_ladder,
    e08_occlusion,
    e09_parameterizations,
    e10_voxel_cone_tracing,
    e11_split_sum,
    e12_engines,
)

EXPERIMENTS: tuple[ModuleType, ...] = (
    e01_diffuse_sh, e02_glossy_lod_bias, e03_fresnel_blends, e04_frame_time, e05_reference_convergence,
    e06_stability, e07_accuracy_time_ladder, e08_occlusion, e09_parameterizations, e10_voxel_cone_tracing,
    e11_split_sum, e12_engines)

_NAME = re.compile(r"^E0*([1-9][0-9]*)$", re.IGNORECASE)


def name(module: ModuleType) -> str:
    """'E8' for the module of experiment 8."""
    return f"E{module.NUMBER}"


def names() -> list[str]:
    """Every experiment's name, in number order."""
    return [name(m) for m in EXPERIMENTS]


def find(text: str) -> ModuleType | None:
    """The experiment named `text` ('E8', 'e8', 'E08', surrounding blanks ignored); None if there is none."""
    match = _NAME.match(text.strip())
    if match is None:
        return None
    number = int(match.group(1))
    return next((m for m in EXPERIMENTS if m.NUMBER == number), None)


def select(texts: list[str]) -> list[ModuleType]:
    """The experiments named in `texts`, each once, in number order; ValueError naming the first unknown
    name and listing the valid ones."""
    chosen = []
    for text in texts:
        module = find(text)
        if module is None:
            raise ValueError(f"{text.strip()!r} is no experiment; valid: {', '.join(names())}")
        chosen.append(module)
    return [m for m in EXPERIMENTS if m in chosen]


def settings_of(module: ModuleType, quick: bool):
    """The module's settings for `--quick` or the full suite."""
    return module.QUICK if quick else module.FULL
