"""Cache folders that cannot take an entry: a clear warning, and the render is still returned.

(Corrupt entries, concurrent writers: tests/groundtruth/test_cache.py; a sweep killed mid-way:
tests/experiments/test_gate_sweep_report.py.)
"""

from __future__ import annotations

import errno
import os
import tempfile

import numpy as np
import pytest

import groundtruth
import scenes
from groundtruth.pathtracer import reference_cache as cache

pytestmark = pytest.mark.mitsuba


def tiny() -> scenes.Scene:
    return scenes.load("builtin:sphere-diffuse").with_overrides({"camera.width": 8, "camera.height": 8,
                                                                "reference.spp": 4})


def test_full_disk_warns_and_returns_the_render(tmp_path, monkeypatch):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))

    def no_space(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(tempfile, "mkstemp", no_space)
    with pytest.warns(cache.CacheWarning, match="No space left on device"):
        out = groundtruth.render(tiny())
    # the render itself, unharmed: bit-identical to an uncached render of the same seed (same variant)
    np.testing.assert_array_equal(out.rgb, groundtruth.render(tiny(), use_cache=False).rgb)
    assert not list((tmp_path / "cache").glob("*.npz"))


def test_read_only_cache_warns_and_returns_the_render(tmp_path, monkeypatch):
    folder = tmp_path / "ro"
    folder.mkdir()
    monkeypatch.setenv("IBLCHECK_CACHE", str(folder))
    if os.geteuid() == 0:  # root writes anyway: simulate the refusal the kernel would give a user
        def read_only(*args, **kwargs):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))

        monkeypatch.setattr(tempfile, "mkstemp", read_only)
    else:
        folder.chmod(0o500)
    with pytest.warns(cache.CacheWarning, match="cannot be written"):
        out = groundtruth.render(tiny())
    assert out.rgb.shape == (8, 8, 3)
