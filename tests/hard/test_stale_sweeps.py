"""Sweeps never serve stale or duplicate rows.

Row ids are keyed by content (the resolved scene, the map's and meshes' bytes, the row and plugin versions),
so editing the scene file, the map or a mesh computes new rows and drops the stale ones; plans are
deduplicated by content; one process writes a results folder at a time.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections import OrderedDict

import numpy as np
import pytest

import scenes
from experiments.cli import main as cli
from experiments.measure.results import RESULTS, FolderBusy, ResultStore, folder_lock
from experiments.paper import e06_hostile_cases as hostile
from experiments.paper.e06_hostile_runs import tiny_scene
from experiments.runs import rows as row_runner
from experiments.runs import sweep
from groundtruth.pathtracer import reference_cache
from scenes.environment import light_array
from scenes.storage import imageio
from tests.hard.common import ROOT


@pytest.fixture
def files(tmp_path):
    """A scene with a map file and a mesh file of its own."""
    imageio.write_exr(tmp_path / "a.exr", np.full((8, 16, 3), 0.5, np.float32))
    (tmp_path / "m.obj").write_text(hostile.cube_obj(False))
    return tiny_scene(tmp_path, "stale", env=str(tmp_path / "a.exr"), shape=str(tmp_path / "m.obj"))


def rid(spec, ov=None) -> str:
    return sweep.row_id(str(spec), ov or {})


EDITS = [  # (what, edit of the folder) -> a new id
    ("kd in the file", lambda f, s: s.write_text(s.read_text().replace('{ type = "blend" }',
                                                                       '{ type = "blend", kd = [0.5, 0.5, 0.5] }'))),
    ("the name", lambda f, s: s.write_text(s.read_text().replace('name = "stale"', 'name = "other"'))),
    ("the camera", lambda f, s: s.write_text(s.read_text().replace("fov_deg = 32.0", "fov_deg = 31.0"))),
    ("the map's bytes", lambda f, s: imageio.write_exr(f / "a.exr", np.full((8, 16, 3), 0.6, np.float32))),
    ("one map pixel", lambda f, s: imageio.write_exr(f / "a.exr", _one_pixel())),
    ("the mesh's bytes", lambda f, s: (f / "m.obj").write_text(hostile.cube_obj(False, 0.51))),
    ("the mesh's normals", lambda f, s: (f / "m.obj").write_text(hostile.cube_obj(True))),
    ("a realtime key", lambda f, s: s.write_text(s.read_text().replace("timing_frames = 1", "timing_frames = 2"))),
    ("the reference spp", lambda f, s: s.write_text(s.read_text().replace("spp = 4", "spp = 5"))),
    ("two_sided", lambda f, s: s.write_text(s.read_text().replace('{ type = "blend" }',
                                                                  '{ type = "blend", two_sided = true }'))),
]


def _one_pixel():
    rgb = np.full((8, 16, 3), 0.5, np.float32)
    rgb[3, 3, 1] = 0.5001
    return rgb


@pytest.mark.parametrize(("what", "edit"), EDITS, ids=[e[0] for e in EDITS])
def test_an_edit_gives_a_new_row_id(files, what, edit):
    before = rid(files)
    edit(files.parent, files)
    assert rid(files) != before


SAME = [  # (what, edit) -> the same id
    ("a comment", lambda f, s: s.write_text("# a comment\n" + s.read_text())),
    ("the [gate] table", lambda f, s: s.write_text(s.read_text() + "[gate]\nmin_psnr = 20.0\n")),
    ("a default written out", lambda f, s: s.write_text(s.read_text().replace("[realtime]\n",
                                                                              "[realtime]\nlod_bias = 0.0\n"))),
    ("the map rewritten with the same pixels", lambda f, s: imageio.write_exr(f / "a.exr", np.full((8, 16, 3), 0.5,
                                                                                                   np.float32))),
    ("the scene file moved", lambda f, s: shutil.copy(s, f / "moved.toml")),
]


@pytest.mark.parametrize(("what", "edit"), SAME, ids=[e[0] for e in SAME])
def test_what_changes_no_measurement_keeps_the_id(files, what, edit):
    before = rid(files)
    edit(files.parent, files)
    after = rid(files.parent / "moved.toml") if what == "the scene file moved" else rid(files)
    assert after == before


def test_the_map_by_content_not_path(files, tmp_path):
    shutil.copy(tmp_path / "a.exr", tmp_path / "copy.exr")
    assert rid(files, {"environment.map": str(tmp_path / "copy.exr")}) == rid(files)


def test_versions_are_part_of_the_id(files, monkeypatch):
    before = rid(files)
    monkeypatch.setattr(row_runner, "ROW_VERSION", row_runner.ROW_VERSION + 1)  # where content_id reads it
    assert rid(files) != before
    monkeypatch.undo()
    from groundtruth.pathtracer import paper_bsdf

    monkeypatch.setattr(paper_bsdf, "PLUGIN_VERSION", paper_bsdf.PLUGIN_VERSION + 1)
    assert rid(files) != before


PLANS = [  # (label, specs, axes) -> the number of rows
    ("--face-sizes 8,8", ["{s}"], dict(face_sizes=[8, 8]), 1),
    ("--face-sizes 8,16,8,16", ["{s}"], dict(face_sizes=[8, 16, 8, 16]), 2),
    ("--axis face_size=8,8.0", ["{s}"], dict(extra=[("realtime.face_size", [8, 8.0])]), 1),
    ("--lod-biases 0,0.0,-0.0", ["{s}"], dict(lod_biases=[0.0, 0.0, -0.0]), 1),
    ("the scene twice", ["{s}", "{s}"], dict(face_sizes=[8, 16]), 2),
    ("the scene through another path", ["{s}", "{d}/./stale.toml", "{d}/../{n}/stale.toml"], dict(face_sizes=[8]), 1),
    ("a copy of the scene file", ["{s}", "{d}/copy.toml"], dict(face_sizes=[8]), 1),
    ("an axis value equal to the scene's", ["{s}"], dict(extra=[("realtime.lod_bias", [0.0])]), 1),
    ("--envs the map, its copy, a relative path", ["{s}"], dict(envs=["{d}/a.exr", "{d}/copy.exr", "{d}/./a.exr"]), 1),
    ("--exponents 100,100.0 (the default)", ["{s}"], dict(exponents=[100.0, 100]), 1),
    ("builtin twice", ["builtin:sphere-diffuse", "builtin:sphere-diffuse"], dict(face_sizes=[8, 8]), 1),
]


@pytest.mark.parametrize(("label", "specs", "axes", "count"), PLANS, ids=[p[0] for p in PLANS])
def test_plans_are_deduplicated_by_content(files, label, specs, axes, count):
    d = files.parent
    shutil.copy(files, d / "copy.toml")
    shutil.copy(d / "a.exr", d / "copy.exr")
    fmt = {"s": files, "d": d, "n": d.name}
    axes = {k: [x.format(**fmt) if isinstance(x, str) else x for x in v] if k == "envs" else v
            for k, v in axes.items()}
    plan = sweep.plan([x.format(**fmt) for x in specs], sweep.Axes(**{"face_sizes": None, "lod_biases": None,
                                                                       **axes}))
    assert len(plan) == count, plan


def fake_row(spec: str, ov: dict, rid_: str):
    row = hostile.hostile_rows()[0]
    from dataclasses import replace

    return replace(row, id=rid_, spec=spec, overrides=ov)


def test_stale_rows_are_found_and_dropped_with_a_warning(files, tmp_path):
    store = ResultStore(tmp_path / RESULTS)
    good = fake_row(str(files), {}, rid(files))
    old = fake_row(str(files), {"realtime.face_size": 8}, "0123456789abcdef")  # an id from before an edit
    gone = fake_row(str(tmp_path / "deleted.toml"), {}, "fedcba9876543210")
    bad_override = fake_row(str(files), {"realtime.face_size": 3}, "aaaaaaaaaaaaaaaa")
    for r in (good, old, gone, bad_override):
        store.append(r)
    assert {r.id for r in sweep.stale(store.read())} == {old.id, gone.id, bad_override.id}
    with pytest.warns(sweep.StaleRowsWarning, match="dropped 3 rows"):
        rows = sweep.drop_stale(store)
    assert [r.id for r in rows] == [good.id] == [r.id for r in store.read()]


@pytest.mark.gl
@pytest.mark.mitsuba
def test_editing_the_scene_reruns_its_rows(files, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "sw"
    args = ["sweep", str(files), "--face-sizes", "4,8,8", "--lod-biases", "0", "--out", str(out)]
    assert cli.main(args) == 0
    first = ResultStore(out / RESULTS).read()
    assert len(first) == 2
    assert cli.main(args) == 0  # resumed: nothing new
    assert [r.id for r in ResultStore(out / RESULTS).read()] == [r.id for r in first]
    imageio.write_exr(tmp_path / "a.exr", np.full((8, 16, 3), 2.0, np.float32))  # a brighter map, same path
    capsys.readouterr()
    assert cli.main(args) == 0
    assert "dropped 2 rows" in capsys.readouterr().err
    second = ResultStore(out / RESULTS).read()
    assert len(second) == 2 and not {r.id for r in first} & {r.id for r in second}
    assert all(a.psnr != b.psnr or a.realtime_ms != b.realtime_ms for a, b in zip(first, second, strict=True))
    html = (out / "index.html").read_text()
    assert html.count("<details>") == 2  # the report shows the new rows only


@pytest.mark.parametrize("argv", [["sweep", "{s}", "--face-sizes", "8", "--lod-biases", "0", "--out", "{o}"],
                                  ["paper", "--quick", "--out", "{o}"], ["report", "{o}"]])
def test_a_second_writer_is_refused(files, tmp_path, capsys, argv):
    out = tmp_path / "out"
    out.mkdir()
    (out / RESULTS).write_text("")
    with folder_lock(out):
        code = cli.main([a.format(s=files, o=out) for a in argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "another iblcheck process is writing" in err[0], err


def test_the_lock_is_released_and_leaves_no_file(tmp_path):
    with folder_lock(tmp_path):
        with pytest.raises(FolderBusy), folder_lock(tmp_path):
            pass
    with folder_lock(tmp_path):
        pass
    assert os.listdir(tmp_path) == []


@pytest.mark.gl
@pytest.mark.mitsuba
def test_two_sweeps_at_once_write_each_row_once(files, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "IBLCHECK_CACHE": str(tmp_path / "cache")}
    out = tmp_path / "both"
    cmd = [sys.executable, "-m", "experiments.cli.main", "sweep", str(files), "--face-sizes", "2,4,8",
           "--lod-biases", "0", "--out", str(out)]
    procs = [subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    results = [(p.wait(timeout=300), p.stderr.read()) for p in procs]
    for code, err in results:
        assert code == 0 or (code == 2 and "another iblcheck process" in err), err
    assert any(code == 0 for code, _ in results)
    ids = [json.loads(x)["id"] for x in (out / RESULTS).read_text().splitlines()]
    assert len(ids) == len(set(ids)) == 3


def _turn_one_direction(directions: np.ndarray) -> np.ndarray:
    """A placement moved by a hundredth of a degree: light 0 turned about +Y."""
    out = directions.copy()
    c, s = np.cos(np.radians(0.01)), np.sin(np.radians(0.01))
    x, z = out[0, 0], out[0, 2]
    out[0, 0], out[0, 2] = c * x + s * z, -s * x + c * z
    return out


def _shift_one_cut(regions: list) -> list:
    """A median cut one texel off: the first region loses its last row (or column) to nothing else;
    the regions still tile the map because its neighbour is grown by the same texels."""
    (r0, r1, c0, c1), *rest = regions
    for i, (q0, q1, p0, p1) in enumerate(rest):
        if (q0, p0, p1) == (r1, c0, c1):  # the region below, the same columns: the row moves to it
            rest[i] = (r1 - 1, q1, p0, p1)
            return [(r0, r1 - 1, c0, c1), *rest]
        if (p0, q0, q1) == (c1, r0, r1):  # the region to the right, the same rows: the column moves to it
            rest[i] = (q0, q1, c1 - 1, p1)
            return [(r0, r1, c0, c1 - 1), *rest]
    raise AssertionError(f"no neighbour of {regions[0]} shares a whole side")


PERTURBATIONS = [  # (placement, count, the function of light_array replaced, the edit of its result)
    ("geodesic", 42, "geodesic_directions", _turn_one_direction),
    ("geodesic", 42, "region_powers", lambda p: p * np.r_[1.0 + 1e-6, np.ones(len(p) - 1)][:, None]),
    ("median_cut", 16, "_median_cut_regions", _shift_one_cut),
    ("median_cut", 16, "region_powers", lambda p: p[::-1].copy()),
]


@pytest.mark.parametrize("changed", [True, False], ids=["changed", "identical"])
@pytest.mark.parametrize(("placement", "count", "function", "edit"), PERTURBATIONS,
                         ids=[f"{p[0]}-{p[2]}" for p in PERTURBATIONS])
def test_a_light_array_reference_is_keyed_by_the_array(monkeypatch, placement, count, function, edit, changed):
    """A reference rendered with the light array (and its row) is keyed by the array's directions and
    powers: the placement code edited to give another array (one light turned by 0.01 degree, one
    power off by a millionth, one median cut moved by a texel, the powers in another order) changes
    the reference cache key, the reference's id and the row id, with the placement and count as they
    were; the same code wrapped to give the same array (the negative control) keeps all three."""
    scene = scenes.load("builtin:sphere-diffuse").with_overrides({
        "realtime.diffuse": "lights", "reference.lighting": "light_array",
        "realtime.lights.placement": placement, "realtime.lights.count": count})
    env = scene.environment.radiance()

    def keys() -> tuple[str, str, str]:
        return (reference_cache.reference_key(scene, env, 8, 0, "v", "3", 4, "direct"),
                row_runner.content_id(scene, reference_only=True), row_runner.content_id(scene))

    before = keys()
    original = getattr(light_array, function)
    monkeypatch.setattr(light_array, function,
                        lambda *a, **k: edit(original(*a, **k)) if changed else original(*a, **k))
    monkeypatch.setattr(light_array, "_DIGESTS", OrderedDict())  # the digests made before the edit
    made = light_array.make(env, placement, count)
    assert made.count == count and np.isfinite(made.powers).all()
    after = keys()
    if changed:
        assert all(a != b for a, b in zip(before, after, strict=True)), (before, after)
    else:
        assert after == before


def test_the_light_array_key_is_cheap_once_made(monkeypatch):
    """The array behind a key is made once per map, placement and count in a process: a second key of
    the same scene does not place the lights again (the map's bytes are hashed to find it)."""
    env = np.full((16, 32, 3), 0.5, np.float32)
    monkeypatch.setattr(light_array, "_DIGESTS", OrderedDict())
    calls = []
    original = light_array.make
    monkeypatch.setattr(light_array, "make", lambda *a: calls.append(a) or original(*a))
    first = light_array.content_digest(env, "geodesic", 42)
    assert light_array.content_digest(env.copy(), "geodesic", 42) == first and len(calls) == 1
    assert light_array.content_digest(env * 2, "geodesic", 42) != first and len(calls) == 2
