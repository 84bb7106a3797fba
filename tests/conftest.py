"""Shared fixtures. Markers: `gl` (OpenGL context), `mitsuba` (Mitsuba 3), `slow`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

PROBE_DIR = Path(__file__).resolve().parents[1] / "scenes" / "data" / "envs"


@pytest.fixture(scope="session")
def mi():
    """Mitsuba with iblcheck's variant choice (llvm_ad_rgb here, never LLVM 15)."""
    from groundtruth.pathtracer.variant import mitsuba

    return mitsuba()


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
