"""Experiments: metrics, compare, sweeps, the CI gate, reports and the paper suite; the `iblcheck` CLI.

    experiments.compare(test, reference, scene) -> dict     (docs/contract.md section 6)
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["compare"]


def __getattr__(name: str) -> Any:
    """`compare`, loaded on first use: the lazy loading of this package, decided here once. The command's entry
    point (experiments/cli/entry.py) is imported through this package and must start before the renderers'
    imports, which it guards against a Ctrl-C."""
    if name in __all__:
        return getattr(import_module("experiments.measure.comparison"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
