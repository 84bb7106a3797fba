"""The reference cache: hits, misses, corruption, concurrency, unwritable folders."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import groundtruth
from groundtruth.pathtracer import reference_cache as cache
from tests.groundtruth.common import small

pytestmark = pytest.mark.mitsuba
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def cache_dir(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("IBLCHECK_CACHE", str(folder))
    return folder


def entries(folder: Path) -> list[Path]:
    return sorted(folder.glob("*.npz"))


def test_second_render_reads_the_cache(cache_dir, mi, monkeypatch):
    scene = small("builtin:sphere-blend", size=32, spp=16)
    first = groundtruth.render(scene)

    def no_render(*args, **kwargs):
        raise AssertionError("the second render must come from the cache, not from Mitsuba")

    monkeypatch.setattr(mi, "render", no_render)  # from here on, Mitsuba cannot render at all
    second = groundtruth.render(scene)
    assert first.meta["cache"] == "miss" and second.meta["cache"] == "hit"
    np.testing.assert_array_equal(first.rgb, second.rgb)
    np.testing.assert_array_equal(first.mask, second.mask)
    assert len(entries(cache_dir)) == 1
    with pytest.raises(AssertionError, match="from the cache"):  # and the patch did bite: a miss renders
        groundtruth.render(scene.with_overrides({"reference.seed": 5}))


@pytest.mark.parametrize(("overrides", "hit"), [
    ({"realtime.lod_bias": 2.0}, True),
    ({"realtime.face_size": 16, "tonemap.key": 0.3}, True),
    ({"objects.0.material.kd": [0.5, 0.5, 0.5]}, False),
    ({"reference.spp": 17}, False),
    ({"reference.seed": 1}, False),
    ({"environment.rotation_deg": 10.0}, False),
    ({"camera.fov_deg": 31.0}, False),
    ({"realtime.diffuse": "lights", "realtime.lights.count": 12}, True),  # a real-time choice: the same reference
    ({"realtime.diffuse": "lights", "reference.lighting": "light_array"}, False),  # the array's own reference
])
def test_key_holds_what_changes_the_reference_and_nothing_else(cache_dir, overrides, hit):
    scene = small("builtin:sphere-blend", size=24, spp=16)
    groundtruth.render(scene)
    again = groundtruth.render(scene.with_overrides(overrides))
    assert (again.meta["cache"] == "hit") is hit


def test_corrupt_entry_is_rerendered_and_said_so(cache_dir):
    scene = small("builtin:sphere-diffuse", size=24, spp=16)
    first = groundtruth.render(scene)
    (entry,) = entries(cache_dir)
    data = bytearray(entry.read_bytes())
    data[len(data) // 2] ^= 0xFF
    entry.write_bytes(bytes(data))
    with pytest.warns(cache.CacheWarning, match="corrupt"):
        again = groundtruth.render(scene)
    assert again.meta["cache"] == "corrupt"
    np.testing.assert_array_equal(again.rgb, first.rgb)  # same seed, same variant: bit-identical
    assert groundtruth.render(scene).meta["cache"] == "hit"  # and the entry is whole again


def test_two_concurrent_processes_leave_one_valid_entry(cache_dir):
    code = ("import groundtruth, scenes; s = scenes.load('builtin:sphere-blend').with_overrides("
            "{'camera.width': 32, 'camera.height': 32, 'reference.spp': 32}); "
            "print(groundtruth.render(s).meta['cache'])")
    env = {**os.environ, "IBLCHECK_CACHE": str(cache_dir), "PYTHONPATH": str(ROOT)}
    procs = [subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, cwd=ROOT) for _ in range(2)]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    assert sorted(o[0].strip() for o in outs) == ["hit", "miss"]  # the lock made the second one wait
    assert len(entries(cache_dir)) == 1
    assert not list(cache_dir.glob("*.tmp"))
    key = entries(cache_dir)[0].stem
    assert cache.load(key) is not None


def test_unwritable_cache_still_returns_the_render(tmp_path, monkeypatch):
    """A cache path under a regular file cannot be created, even by root: warn, render anyway."""
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("")
    monkeypatch.setenv("IBLCHECK_CACHE", str(blocker / "cache"))
    scene = small("builtin:sphere-diffuse", size=16, spp=4)
    with pytest.warns(cache.CacheWarning, match="cannot be written"):
        out = groundtruth.render(scene)
    assert out.rgb.shape == (16, 16, 3) and out.meta["cache"] == "miss"


def test_the_light_array_reference_is_keyed_by_its_placement_and_count(cache_dir):
    scene = small("builtin:sphere-blend", size=24, spp=16).with_overrides(
        {"realtime.diffuse": "lights", "reference.lighting": "light_array", "realtime.lights.count": 12})
    groundtruth.render(scene)
    assert groundtruth.render(scene.with_overrides({"realtime.lights.count": 42})).meta["cache"] == "miss"
    assert groundtruth.render(scene.with_overrides({"realtime.lights.placement": "median_cut",
                                                    "realtime.lights.count": 16})).meta["cache"] == "miss"
    assert groundtruth.render(scene).meta["cache"] == "hit"


@pytest.mark.parametrize("edit, says", [
    (lambda rgb, mask, meta: (np.where(np.arange(rgb.size).reshape(rgb.shape) == 5, np.nan, rgb), mask, meta),
     "NaN or Inf"),
    (lambda rgb, mask, meta: (rgb, mask[:-1], meta), "mask holds"),
    (lambda rgb, mask, meta: (rgb, mask, {**meta, "key": "another"}), "not this key's"),
    (lambda rgb, mask, meta: (rgb, mask, {**meta, "spp": -1}), "spp = -1"),
    (lambda rgb, mask, meta: (rgb, mask, {**meta, "render_ms": float("inf")}), "render_ms = inf"),
])
def test_an_entry_written_whole_with_meaningless_content_is_rerendered(cache_dir, edit, says):
    """The checksum proves an entry was written whole, not that what it holds means anything: an entry
    re-written with a valid checksum over NaN radiance, a mask of another size, another key's record,
    a negative spp or an infinite time is refused by what it says and rendered again."""
    scene = small("builtin:sphere-diffuse", size=24, spp=16)
    first = groundtruth.render(scene)
    (entry,) = entries(cache_dir)
    rgb, mask, meta = cache.load(entry.stem)
    rgb, mask, meta = edit(rgb, mask, meta)
    meta_json = json.dumps(meta, sort_keys=True)
    cache.write_npz(cache_dir, entry.stem, rgb=rgb, mask=mask, meta=np.array(meta_json),
                    checksum=np.array(cache._checksum(rgb, mask, meta_json)))
    with pytest.warns(cache.CacheWarning, match=says):
        again = groundtruth.render(scene)
    assert again.meta["cache"] == "corrupt"
    np.testing.assert_array_equal(again.rgb, first.rgb)
