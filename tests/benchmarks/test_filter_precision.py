"""benchmarks/gpu/filter_precision.py: the texture unit's weight precision, read off a sweep between 0 and 1.

On any GL the sweep must be consistent with itself: exact float filtering (all 4096 values distinct) lies on
the line y = t to float precision; a unit that quantises to b bits returns 2^b + 1 steps and misses the line by
at most one step, 2^-b. The H200 measured 8 bits (reports/gpu/gl-tests-h200/filter-precision.json).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("filter_precision", ROOT / "benchmarks" / "gpu" / "filter_precision.py")
filter_precision = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = filter_precision
_spec.loader.exec_module(filter_precision)


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


@pytest.mark.gl
def test_the_json_written_is_what_is_printed(tmp_path, capsys):
    assert filter_precision.main(["--out", str(tmp_path / "f.json")]) == 0
    assert (tmp_path / "f.json").read_text() == capsys.readouterr().out
