"""Numbers read back from iblcheck's own files are checked for their meaning, not only their type.

A baseline, a results.jsonl row, the measured arrays kept beside a row and a PRT cache entry can be
edited by hand or corrupted into numbers of the right type and no meaning. The gate acts on them (a
baseline `mse_se` of -1 widens the PSNR tolerance from 0.29 dB to 24.6 dB), so each file that holds such
a number is refused with exit 2 naming the file and the field (experiments/measure/fields.py), and a
PRT cache entry is recomputed with a CacheWarning. Every group has a negative control: the valid file.
"""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pytest

from experiments.cli import main as cli
from experiments.measure import fields
from experiments.measure.results import ResultRow, ResultStore
from experiments.publish import images
from experiments.runs import gate
from scenes import InputError
from scenes.storage.disk_cache import CacheWarning
from tests.experiments.test_gate_baseline import good_file, record
from tests.experiments.test_sweep_axes import row

# --------------------------------------------------------------------------- the ranges themselves


def test_the_ranges_follow_the_metrics_definitions():
    """Independent of the table: display values lie in [0, 1], so MSE <= 1 and PSNR = 10 log10(1 / MSE)
    >= 0; PSNR is capped at 100 dB; SSIM lies in [-1, 1]."""
    assert fields.problem("psnr", 10 * math.log10(1 / 1.0)) is None  # the worst possible image
    assert fields.problem("psnr", 100.0) is None and fields.problem("psnr", 100.5)
    assert fields.problem("ssim", -1.0) is None and fields.problem("ssim", 1.0 + 1e-9)
    assert fields.problem("mse_se", 0.0) is None and "standard error" in fields.problem("mse_se", -1e-12)
    assert fields.problem("pixels", 1.0) and fields.problem("pixels", True)  # counts are integers
    assert fields.problem("unknown_field", -1) is None


def test_a_negative_mse_se_would_have_widened_the_tolerance():
    """Why: with the file accepted, mse_se = -1 turns 0.29 dB into ~24.6 dB (module docstring)."""
    new = record(psnr=29.0, ref="r1")
    base = record(ref="r0")
    sane = gate.psnr_tolerance_db(base["metrics"], new["metrics"], False)
    base["metrics"]["mse_se"] = -1.0
    assert gate.psnr_tolerance_db(base["metrics"], new["metrics"], False) > 20 * sane


# --------------------------------------------------------------------------- gate baselines

BAD_RECORDS = [  # (metric key, value, words in the error)
    ("mse_se", -1.0, "standard error"), ("ssim_se", -0.001, "standard error"), ("flip_se", -1e-9, "standard error"),
    ("psnr", -3.0, "PSNR"), ("psnr", 250.0, "PSNR"), ("noise_floor_psnr", -1.0, "PSNR"),
    ("noise_floor_psnr", 1e300, "PSNR"), ("ssim", 1.5, "SSIM"), ("ssim", -2.0, "SSIM"), ("flip", -0.1, "FLIP"),
    ("flip", 2.0, "FLIP"), ("pixels", 0, "0 pixels beside a psnr"), ("pixels", 2.5, "count of pixels"),
    ("pixels", True, "count of pixels"), ("ssim_noise_slope", "steep", "slope"),
]


@pytest.mark.parametrize(("key", "value", "words"), BAD_RECORDS, ids=[f"{k}={v}" for k, v, _ in BAD_RECORDS])
def test_a_baseline_number_without_meaning_is_refused(tmp_path, key, value, words):
    tree = good_file()
    (entry,) = tree["scenes"].values()
    entry["metrics"][key] = value
    path = tmp_path / "base.json"
    path.write_text(json.dumps(tree))
    with pytest.raises(gate.BaselineError) as err:
        gate.read_baseline(path)
    msg = str(err.value)
    assert str(path) in msg and f"metrics.{key}" in msg and words in msg, msg


@pytest.mark.parametrize("timings", [{"total": -1.0}, {"total": 5.0, "draw": -2.0}, {"total": None}])
def test_baseline_times_must_be_times(tmp_path, timings):
    tree = good_file()
    (entry,) = tree["scenes"].values()
    entry["timings"] = {"realtime_ms": timings}
    path = tmp_path / "base.json"
    path.write_text(json.dumps(tree))
    with pytest.raises(gate.BaselineError, match=r"timings\.realtime_ms\.(total|draw)"):
        gate.read_baseline(path)


def test_valid_baselines_still_read(tmp_path):
    """Negative control: the good file, and a record of an empty comparison (null metrics, 0 pixels)."""
    tree = good_file()
    (entry,) = tree["scenes"].values()
    entry["metrics"].update(psnr=None, ssim=None, flip=None, noise_floor_psnr=None, pixels=0, ssim_se=0.0,
                            ssim_noise_slope=-0.3)
    path = tmp_path / "base.json"
    path.write_text(json.dumps(tree))
    assert gate.read_baseline(path)["scenes"]


def test_gate_cli_refuses_a_negative_standard_error_with_exit_2(tmp_path, capsys, monkeypatch):
    tree = good_file()
    (entry,) = tree["scenes"].values()
    entry["metrics"]["mse_se"] = -1
    path = tmp_path / "base.json"
    path.write_text(json.dumps(tree))
    monkeypatch.setattr(gate, "measure", lambda *a, **k: pytest.fail("rendered before the baseline was read"))
    code = cli.main(["gate", "builtin:sphere-phong", "--baseline", str(path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and str(path) in err[0] and "mse_se" in err[0], err


# --------------------------------------------------------------------------- results.jsonl rows

BAD_ROWS = [
    ({"psnr": -3.0}, "psnr"), ({"psnr": float("nan")}, "psnr"), ({"ssim": 1.01}, "ssim"), ({"flip": -0.5}, "flip"),
    ({"rel_mse": -1.0}, "rel_mse"), ({"noise_floor_psnr": 400.0}, "noise_floor_psnr"), ({"width": 0}, "width"),
    ({"height": -8}, "height"), ({"face_size": -1}, "face_size"), ({"reference_spp": 0}, "reference_spp"),
    ({"reference_s": -2.0}, "reference_s"), ({"pixels": 0}, "pixels"), ({"pixels": -4}, "pixels"),
    ({"realtime_ms": {"total": -1.0}}, "realtime_ms.total"),
    ({"realtime_p90_ms": {"draw": -0.1}}, "realtime_p90_ms.draw"),
    ({"psnr_unbiased": -0.5}, "psnr_unbiased"), ({"equal_quality_s": -3.0}, "equal_quality_s"),
]


@pytest.mark.parametrize(("change", "field"), BAD_ROWS, ids=[b[1] + str(i) for i, b in enumerate(BAD_ROWS)])
def test_a_result_row_without_meaning_is_refused_naming_file_line_and_field(tmp_path, change, field):
    store = ResultStore(tmp_path / "results.jsonl")
    store.append(row(0))
    with open(store.path, "a") as f:  # json.dumps writes NaN unless told not to: as a hand edit would
        f.write(json.dumps({**row(1).to_dict(), **change}) + "\n")
    with pytest.raises(InputError) as err:
        store.read()
    msg = str(err.value)
    assert str(store.path) in msg and "line 2" in msg and field in msg, msg


def test_valid_rows_still_read(tmp_path):
    """Negative control: ordinary rows, and a failed row (null metrics, 0 pixels, face size 0)."""
    store = ResultStore(tmp_path / "results.jsonl")
    failed = ResultRow(**{**row(1).__dict__, "psnr": None, "ssim": None, "flip": None, "rel_mse": None,
                          "noise_floor_psnr": None, "pixels": 0, "face_size": 0, "error": "reference failed",
                          "realtime_ms": {"total": None}})
    for r in (row(0), failed):
        store.append(r)
    assert [r.id for r in store.read()] == ["r0", "r1"]


# --------------------------------------------------------------------------- measured.npz beside a row


def save(path, **over):
    arrays = {"rgb": np.full((8, 8, 3), 0.5, np.float32), "coverage": np.ones((8, 8), bool),
              "meta": np.array(json.dumps({"face_size": 16})), "mask": np.ones((8, 8), bool),
              "error": np.full((8, 8), 0.1, np.float32)}
    arrays.update(over)
    arrays = {k: v for k, v in arrays.items() if v is not None}
    path.parent.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    path.write_bytes(buf.getvalue())


def row_with(rel: str) -> ResultRow:
    return ResultRow(**{**row(0).__dict__, "images": {images.ARRAYS: rel}})  # row(0) is 8 x 8


BAD_ARRAYS = [
    ({"rgb": np.full((8, 8, 3), np.nan, np.float32)}, "rgb"), ({"rgb": np.zeros((4, 8, 3), np.float32)}, "rgb"),
    ({"rgb": np.zeros((8, 8, 3), np.int32)}, "rgb"), ({"coverage": np.ones((8, 8), np.uint8)}, "coverage"),
    ({"mask": np.ones((8, 7), bool)}, "mask"), ({"error": np.full((8, 8), 3.0, np.float32)}, "error"),
    ({"error": np.full((8, 8), -0.1, np.float32)}, "error"), ({"meta": np.array("[1, 2]")}, "meta"),
    ({"meta": np.array("{not json")}, "measured arrays"), ({"error": None}, "'error'"),
]


@pytest.mark.parametrize(("over", "words"), BAD_ARRAYS, ids=[f"npz{i}" for i in range(len(BAD_ARRAYS))])
def test_measured_arrays_without_meaning_are_refused(tmp_path, over, words):
    path = tmp_path / "images" / "r0" / "measured.npz"
    save(path, **over)
    with pytest.raises(InputError) as err:
        images.load_measured(tmp_path, row_with("images/r0/measured.npz"))
    assert str(path) in str(err.value) and words in str(err.value), str(err.value)


def test_measured_arrays_garbage_and_a_path_outside_the_folder(tmp_path):
    path = tmp_path / "images" / "m.npz"
    path.parent.mkdir()
    path.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(InputError, match="not the measured arrays"):
        images.load_measured(tmp_path, row_with("images/m.npz"))
    outside = tmp_path.parent / f"{tmp_path.name}-outside.npz"
    save(outside)
    with pytest.raises(InputError, match="leaves the results folder"):
        images.load_measured(tmp_path, row_with(f"../{outside.name}"))


def test_valid_measured_arrays_still_load(tmp_path):
    """Negative control."""
    save(tmp_path / "images" / "r0" / "measured.npz")
    kept = images.load_measured(tmp_path, row_with("images/r0/measured.npz"))
    assert kept.test.rgb.shape == (8, 8, 3) and kept.test.meta == {"face_size": 16}
    assert kept.error.max() == np.float32(0.1)


# --------------------------------------------------------------------------- PRT cache entries


def _rewrite_meta(path, **change):
    from realtime.techniques.prt import prt_transfer as prt

    with np.load(path) as z:
        entry = dict(z)
    meta = {**json.loads(str(entry["meta"])), **change}
    meta = {k: v for k, v in meta.items() if v is not ...}
    meta_json = json.dumps(meta, sort_keys=True)
    arrays = [entry[f"t{i}"] for i in range(sum(k.startswith("t") for k in entry))]
    entry["meta"], entry["checksum"] = np.array(meta_json), np.array(prt._entry_checksum(arrays, meta_json))
    with open(path, "wb") as f:
        np.savez(f, **entry)


BAD_META = [{"version": 99}, {"version": True}, {"rays_traced": -5}, {"rays_traced": 1}, {"rays_traced": ...},
            {"vertices": 3}, {"seconds": -1.0}, {"seconds": "fast"}]


@pytest.mark.parametrize("change", BAD_META, ids=[f"meta{i}" for i in range(len(BAD_META))])
def test_a_prt_cache_entry_without_meaning_is_recomputed(tmp_path, monkeypatch, change):
    trimesh = pytest.importorskip("trimesh")
    pytest.importorskip("embreex")
    from realtime.techniques.prt.prt_transfer import TransferObject, cached_transfer

    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path))
    mesh = trimesh.creation.icosphere(1)
    obj = TransferObject(np.asarray(mesh.vertices, np.float32), np.asarray(mesh.vertex_normals, np.float32),
                         np.asarray(mesh.faces, np.uint32), np.array([0.5, 0.5, 0.5], np.float32))
    good, info = cached_transfer([obj], 2, 8, 0, True)
    assert cached_transfer([obj], 2, 8, 0, True)[1]["cached"]  # negative control: a valid entry is used
    _rewrite_meta(tmp_path / "prt" / f"{info['key']}.npz", **change)
    with pytest.warns(CacheWarning, match="corrupt"):
        again, info2 = cached_transfer([obj], 2, 8, 0, True)
    assert not info2["cached"] and np.array_equal(again[0], good[0])
    assert info2["rays_traced"] == len(mesh.vertices) * 8
