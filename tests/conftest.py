"""Shared fixtures. Markers: `gl` (OpenGL context), `mitsuba` (Mitsuba 3), `slow`.

Every test run starts from an empty disk cache (references, PRT transfers): `IBLCHECK_CACHE` points at a
new temporary folder for the run, shared by its xdist workers and removed at the end. A cache key holds
everything a scene determines, but not the code that renders it, so a cache kept between runs would let a
test pass on an entry an older (or, under mutation testing, an unmutated) renderer wrote. Under mutmut every
mutant's pytest session gets its own folder. Tests that need a cache of their own still set the variable.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

#: set while IBLCHECK_CACHE is the run's fresh folder (xdist workers inherit it from the controller)
_FRESH_CACHE = "IBLCHECK_TEST_FRESH_CACHE"
_cache_key = pytest.StashKey[str]()


def pytest_configure(config: pytest.Config) -> None:
    inherited = os.environ.get(_FRESH_CACHE)
    if inherited and os.environ.get("PYTEST_XDIST_WORKER"):
        return  # a worker of a run whose controller made the folder
    folder = tempfile.mkdtemp(prefix="iblcheck-test-cache-")
    os.environ["IBLCHECK_CACHE"] = os.environ[_FRESH_CACHE] = folder
    config.stash[_cache_key] = folder


def pytest_unconfigure(config: pytest.Config) -> None:
    folder = config.stash.get(_cache_key, None)
    if folder:
        shutil.rmtree(folder, ignore_errors=True)


PROBE_DIR = Path(__file__).resolve().parents[1] / "scenes" / "data" / "envs"


@pytest.fixture(scope="session")
def mi():
    """Mitsuba with iblcheck's variant choice (llvm_ad_rgb here, never LLVM 15)."""
    from groundtruth.pathtracer.variant import mitsuba

    return mitsuba()


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
