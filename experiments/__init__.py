"""Experiments: metrics, compare, sweeps, the CI gate, reports and the paper suite; the `iblcheck` CLI.

    experiments.compare(test, reference, scene) -> dict     (docs/contract.md section 6)
"""

from experiments.measure.comparison import compare

__all__ = ["compare"]
