"""benchmarks/gpu/filter_precision.py: the texture unit's weight precision, read off a sweep between 0 and 1.

On any GL the sweep must be consistent with itself: exact float filtering (all 4096 values distinct) lies on
the line y = t to float precision; a unit that quantises to b bits returns 2^b + 1 steps and misses the line by
at most one step, 2^-b. The H200 measured 8 bits (reports/gpu/gl-tests-h200/filter-precision.json).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("filter_precision", ROOT / "benchmarks" / "gpu" / "filter_precision.py")
filter_precision = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = filter_precision
_spec.loader.exec_module(filter_precision)


@pytest.mark.parametrize("quantise, bits, error", [
    (lambda t: np.round(t * 256) / 256, 8.0, 2.0**-9),   # rounded to 8 bits: the H200's bilinear weight
    (lambda t: np.floor(t * 256) / 256, 8.0, 2.0**-8),   # truncated: its LOD fraction (the last step at t = 1)
    (lambda t: np.round(t * 64) / 64, 6.0, 2.0**-7),
], ids=["round-8", "truncate-8", "round-6"])
def test_the_steps_of_a_quantised_sweep_give_its_bits(quantise, bits, error):
    t = (np.arange(filter_precision.N) + 0.0) / (filter_precision.N - 1)
    got = filter_precision.weight_steps(quantise(t), t)
    assert got["weight_bits"] == bits and got["distinct_values"] == 2 ** int(bits) + 1
    assert got["max_abs_error"] == pytest.approx(error, rel=0.02)


def test_an_exact_sweep_has_no_bits():
    t = np.linspace(0.0, 1.0, filter_precision.N)
    got = filter_precision.weight_steps(t.astype(np.float32).astype(np.float64), t)
    assert got["weight_bits"] is None and got["max_abs_error"] < 1e-7


@pytest.mark.gl
@pytest.mark.parametrize("kind", ["bilinear", "trilinear_lod"])
def test_the_sweep_is_the_line_or_its_quantised_steps(kind):
    result = filter_precision.measure()[kind]
    bits = result["weight_bits"]
    if bits is None:
        assert result["distinct_values"] == filter_precision.N and result["max_abs_error"] < 1e-6
    else:
        assert bits >= 6 and result["distinct_values"] == 2 ** round(bits) + 1
        assert result["max_abs_error"] <= 2.0 ** -round(bits) + 1e-6
