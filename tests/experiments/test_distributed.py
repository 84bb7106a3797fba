"""Sweeps on a real Dask LocalCluster (experiments/runs/dask_cluster.py): 48 x 48 pixels, 32 spp, 2 timed frames.

- a Dask sweep writes the same rows as a serial one (timings, host and cache status aside);
- a seeded reference is bit-identical whichever worker (or the driver) rendered it;
- a task that raises gives a row with the error, the rest completes, and the next run computes it;
- a worker killed mid-task: its task is retried elsewhere, every row comes out once;
- the driver killed: its workers go with it, and the rerun resumes from results.jsonl;
- a worker without a usable Mitsuba variant is reported (and none usable is exit 3's error).
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from experiments.measure.results import ResultStore
from experiments.runs import sweep

pytestmark = [pytest.mark.gl, pytest.mark.mitsuba, pytest.mark.slow]
ROOT = Path(__file__).resolve().parents[2]
TINY = {"camera.width": 48, "camera.height": 48, "reference.spp": 32, "realtime.timing_frames": 2,
        "realtime.warmup_frames": 1}
#: 4 rows, 2 distinct references (a LOD bias does not change one): 4 reference tasks
AXES = sweep.Axes(face_sizes=[16], lod_biases=[0.0, 1.0], exponents=[20.0, 200.0])
#: what may differ between two runs of the same rows: timings, where they ran, cache hits
VOLATILE = {"realtime_ms", "realtime_p90_ms", "reference_s", "reference_cache", "host", "gl_renderer"}


@pytest.fixture(scope="module")
def cluster():
    from experiments.runs.dask_cluster import Cluster

    with Cluster(workers=2, echo=None) as c:
        yield c


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    path = tmp_path / "cache"
    monkeypatch.setenv("IBLCHECK_CACHE", str(path))
    return path


def _stable(row) -> dict:
    return {k: v for k, v in row.to_dict().items() if k not in VOLATILE}


def _pickle_by_value() -> None:
    """Functions of this test module go to the workers by value (they cannot import it)."""
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])


def _log(cache_dir: str, name: str, text: str) -> None:
    """A line in a file of the driver's cache folder (a local cluster's tasks get its path)."""
    Path(cache_dir).mkdir(parents=True, exist_ok=True)
    with open(Path(cache_dir) / name, "a") as f:
        f.write(text + "\n")


def failing_reference(payload, seed, expect, cache_dir=None, use_cache=True):
    """The real task, except that the N = 200 scene raises (on every try)."""
    from experiments.runs.dask_cluster import reference_task

    if payload["tree"]["objects"][0]["material"].get("exponent") == 200.0:
        _log(cache_dir, "attempts.log", f"{seed} {os.getpid()}")
        raise ValueError("injected failure for N = 200")
    return reference_task(payload, seed, expect, cache_dir, use_cache)


def slow_reference(payload, seed, expect, cache_dir=None, use_cache=True):
    """The real task, one second longer (so that a kill lands mid-task)."""
    from experiments.runs.dask_cluster import reference_task

    _log(cache_dir, "starts.log", f"{expect}-{seed} {os.getpid()}")
    time.sleep(1.0)
    return reference_task(payload, seed, expect, cache_dir, use_cache)


def test_dask_rows_equal_serial_rows(tmp_path, cache, monkeypatch, cluster):
    serial = sweep.run(["builtin:sphere-blend"], AXES, tmp_path / "serial", sets=TINY, report=False)
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache-dask"))  # the workers render everything again
    dask_rows = sweep.run(["builtin:sphere-blend"], AXES, tmp_path / "dask", sets=TINY, report=False, cluster=cluster)
    assert len(serial) == len(dask_rows) == 4
    assert len({r.id for r in dask_rows}) == 4
    assert {r.id: _stable(r) for r in dask_rows} == {r.id: _stable(r) for r in serial}
    for r in dask_rows:
        assert r.error is None and r.host and r.gl_renderer
    # the workers wrote the entries into the driver's cache folder (2 references x 2 seeds), bit for bit
    # the serial run's
    written = sorted(p.name for p in (tmp_path / "cache-dask").glob("*.npz"))
    assert written == sorted(p.name for p in cache.glob("*.npz")) and len(written) == 4
    for name in written:
        with np.load(cache / name) as a, np.load(tmp_path / "cache-dask" / name) as b:
            assert np.array_equal(a["rgb"], b["rgb"]) and np.array_equal(a["mask"], b["mask"])


def test_seeded_reference_is_bit_identical_on_every_worker(cache, cluster):
    import scenes
    from experiments.runs.dask_cluster import reference_task, scene_payload
    from experiments.runs.sweep import content_id
    from groundtruth.pathtracer import reference

    scene = scenes.load("builtin:sphere-phong").with_overrides(TINY)
    ref_id = content_id(scene, reference_only=True)
    workers = sorted(cluster.client.scheduler_info()["workers"])
    assert len(workers) == 2
    futures = [cluster.client.submit(reference_task, scene_payload(scene), 7, ref_id, None, False, workers=[w],
                                     allow_other_workers=False, pure=False) for w in workers]
    results = cluster.client.gather(futures)
    assert len({r["pid"] for r in results}) == 2  # two processes rendered it
    here = reference.render(scene, seed=7, use_cache=False)
    for r in results:
        assert r["render"].meta["variant"] == here.meta["variant"]
        assert np.array_equal(r["render"].rgb, here.rgb) and np.array_equal(r["render"].mask, here.mask)


def test_a_task_that_raises_gives_an_error_row_and_the_rest_completes(tmp_path, cache, cluster):
    from experiments.runs.dask_cluster import reference_task

    _pickle_by_value()
    out = tmp_path / "sweep"
    cluster.reference_fn = failing_reference
    try:
        rows = sweep.run(["builtin:sphere-blend"], AXES, out, sets=TINY, report=False, cluster=cluster)
    finally:
        cluster.reference_fn = reference_task
    assert len(rows) == 4 and len({r.id for r in rows}) == 4
    bad = [r for r in rows if r.error]
    assert {r.exponent for r in bad} == {200.0} and len(bad) == 2
    assert all("injected failure for N = 200" in r.error and "after 3 tries" in r.error for r in bad)
    assert all(r.psnr is None and r.pixels == 0 for r in bad)
    assert all(r.psnr is not None for r in rows if not r.error)
    attempts = (cache / "attempts.log").read_text().split()
    assert len(attempts) == 2 * 2 * 3  # two seeds, each tried 1 + RETRIES times
    # the next run computes the failed rows again (and only those), each id once in the file
    again = sweep.run(["builtin:sphere-blend"], AXES, out, sets=TINY, report=False, cluster=cluster)
    assert len(again) == 4 and len({r.id for r in again}) == 4 and not any(r.error for r in again)
    assert [r.id for r in again[:2]] == [r.id for r in rows if not r.error]


def test_worker_killed_mid_task_is_retried_and_every_row_comes_out_once(tmp_path, cache):
    from experiments.runs.dask_cluster import Cluster

    _pickle_by_value()
    killed: list[int] = []
    with Cluster(workers=2, echo=None) as c:
        c.reference_fn = slow_reference
        pids = c.client.run(os.getpid)

        def kill_one_mid_task():
            # The task itself logs its start, so the kill lands inside its one-second sleep; the scheduler's
            # view of what a worker is processing includes tasks that have not started yet.
            starts = cache / "starts.log"
            worker_pids = set(pids.values())
            deadline = time.time() + 60
            while time.time() < deadline:
                lines = starts.read_text().splitlines() if starts.exists() else []
                running = [int(p[1]) for p in map(str.split, lines) if len(p) == 2 and int(p[1]) in worker_pids]
                if running:
                    time.sleep(0.3)
                    os.kill(running[0], signal.SIGKILL)
                    killed.append(running[0])
                    return
                time.sleep(0.02)

        killer = threading.Thread(target=kill_one_mid_task, daemon=True)
        killer.start()
        rows = sweep.run(["builtin:sphere-blend"], AXES, tmp_path / "sweep", sets=TINY, report=False, cluster=c)
        killer.join()
        retried = set(c.stats.retried)
    assert killed, "no worker was killed"
    starts = [line.split() for line in (cache / "starts.log").read_text().splitlines()]
    on_killed = [task for task, pid in starts if int(pid) == killed[0]]
    assert on_killed, "the killed worker had started no task"
    for task in on_killed:  # started again in another process, and finished there
        assert any(t == task and int(pid) != killed[0] for t, pid in starts)
    assert len(rows) == 4 and len({r.id for r in rows}) == 4
    assert not any(r.error for r in rows)
    assert retried, "the killed worker's task should count as retried"
    lines = (tmp_path / "sweep" / sweep.RESULTS).read_text().splitlines()
    assert len(lines) == 4 and len({json.loads(line)["id"] for line in lines}) == 4


def _children(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True).stdout
    return [int(p) for p in out.split()]


def _cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    stat = Path(f"/proc/{pid}/stat")
    return not (stat.exists() and stat.read_text().split(")")[-1].split()[0] == "Z")


def test_driver_killed_its_workers_exit_and_the_rerun_resumes(tmp_path, cache):
    out = tmp_path / "sweep"
    cmd = [sys.executable, "-m", "experiments.cli.main", "sweep", "builtin:sphere-blend", "--face-sizes", "16",
           "--lod-biases", "0,1,2", "--exponents", "20,200", "--out", str(out), "--workers", "2"]
    for k, v in TINY.items():
        cmd += ["--set", f"{k}={v}"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    results = out / sweep.RESULTS
    workers: set[int] = set()
    try:
        deadline = time.time() + 120
        while time.time() < deadline and proc.poll() is None:
            # a worker's title names dask when setproctitle is installed, otherwise it is a spawned child
            workers |= {p for p in _children(proc.pid) if b"dask" in _cmdline(p) or b"spawn_main" in _cmdline(p)}
            if results.exists() and len(results.read_text().splitlines()) >= 1:
                break
            time.sleep(0.05)
        os.kill(proc.pid, signal.SIGKILL)  # the driver alone
        proc.wait()
        deadline = time.time() + 20
        while time.time() < deadline and any(_alive(p) for p in workers):
            time.sleep(0.1)
        orphans = [p for p in workers if _alive(p)]
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)  # whatever is left of the run
        except ProcessLookupError:
            pass
    assert len(workers) == 2, "the driver should have started two worker processes"
    assert not orphans, "worker processes outlived their driver"
    first = ResultStore(results).read()
    assert 1 <= len(first) < 6, "the kill should land mid-way"
    done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rows = ResultStore(results).read()
    assert len(rows) == 6 and len({r.id for r in rows}) == 6 and not any(r.error for r in rows)
    assert [r.id for r in rows[: len(first)]] == [r.id for r in first]  # nothing lost
    assert "dask: 2 workers" in done.stdout


def test_a_worker_without_a_mitsuba_variant_is_reported(monkeypatch):
    from experiments.runs.dask_cluster import Cluster
    from scenes import MissingCapability

    monkeypatch.setenv("IBLCHECK_VARIANT", "no_such_variant")  # the spawned worker inherits it
    lines: list[str] = []
    with pytest.raises(MissingCapability, match="no Dask worker has a usable Mitsuba variant"):
        Cluster(workers=1, echo=lines.append).start()
    assert any("UNUSABLE" in line and "no_such_variant" in line for line in lines), lines


def test_paper_suite_rows_on_the_cluster_equal_serial_rows(tmp_path, cache, monkeypatch, cluster):
    from experiments.paper import e01_diffuse_sh as e1
    from experiments.paper import e02_glossy_lod_bias as e2
    from experiments.paper.context import Common, Context

    common, settings = Common(size=48, spp=32, frames=2), e1.Settings(faces=(8, 16))
    serial = Context(tmp_path / "serial", common, lambda: None)
    serial_e1 = e1.run(serial, settings)
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache-dask"))
    context = Context(tmp_path / "dask", common, lambda: None, cluster)
    context.prefetch([(e1.SPEC, {}), e2.reference_plan()[0]], quadratures=(e1.SPEC,))
    assert len(list((tmp_path / "cache-dask").glob("*.npz"))) == 4  # prefetched: 2 references x 2 seeds
    dask_e1 = e1.run(context, settings)
    rows = [context.done[i] for i in context.used]
    assert [_stable(r) for r in rows] == [_stable(serial.done[i]) for i in serial.used]
    assert all(r.host and r.gl_renderer for r in rows)
    # the same table but for the times (filter and draw ms, the brute-force seconds measured on a worker)
    def untimed(section):
        return [line.split("|")[:6] for line in section.markdown.split("\n\n")[0].splitlines()]

    assert untimed(dask_e1) == untimed(serial_e1)


def test_sweep_on_a_running_scheduler_hands_the_references_back(tmp_path, cache):
    """`dask scheduler` + `dask worker` started apart (as on other machines, with their own cache folder):
    `--scheduler ADDRESS` uses them, the worker caches what it rendered, the driver stores what it got."""
    dask = str(Path(sys.executable).parent / "dask")
    file = tmp_path / "scheduler.json"
    worker_cache = tmp_path / "worker-cache"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "IBLCHECK_CACHE": str(worker_cache)}
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                               "--scheduler-file", str(file)], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, start_new_session=True)]
    try:
        deadline = time.time() + 60
        while not file.exists() and time.time() < deadline:
            time.sleep(0.1)
        procs.append(subprocess.Popen([dask, "worker", "--scheduler-file", str(file), "--nworkers", "1",
                                       "--nthreads", "1", "--no-dashboard"], cwd=tmp_path, env=env,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
        address = json.loads(file.read_text())["address"]
        from distributed import Client

        with Client(address, timeout=30) as c:
            c.wait_for_workers(1, timeout=60)
        lines: list[str] = []
        from experiments.runs.dask_cluster import Cluster

        with Cluster(scheduler=address, echo=lines.append) as cl:
            rows = sweep.run(["builtin:sphere-blend"], AXES, tmp_path / "sweep", sets=TINY, report=False, cluster=cl)
            assert cl.quiet_timing  # its worker shares this host: frames are timed once it is idle
    finally:
        for p in procs:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.pid, signal.SIGTERM)
        for p in procs:
            p.wait(timeout=30)
    assert any("1 workers" in line for line in lines), lines
    assert len(rows) == 4 and not any(r.error for r in rows)
    mine = sorted(p.name for p in cache.glob("*.npz"))
    assert len(mine) == 4 and mine == sorted(p.name for p in worker_cache.glob("*.npz"))


def test_prt_precomputation_is_a_task_and_the_driver_reads_its_entry(tmp_path, cache, monkeypatch, cluster):
    """PRT's transfer (numpy + Embree) is computed on a worker into the PRT cache; the driver's `prepare`
    reads that very entry (no second entry of its own), and the rows equal a serial run's."""
    spec = str(ROOT / "scenes/data/scenes/sphere-on-plane.toml")
    axes = sweep.Axes(face_sizes=[16], lod_biases=None, extra=[("realtime.prt.order", [2, 3])])
    prt = {**TINY, "realtime.diffuse": "prt", "realtime.occlusion": "prt", "realtime.prt.rays": 16}
    serial = sweep.run([spec], axes, tmp_path / "serial", sets=prt, report=False)
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache-dask"))
    rows = sweep.run([spec], axes, tmp_path / "dask", sets=prt, report=False, cluster=cluster)
    assert len(rows) == 2 and not any(r.error for r in rows)
    assert {r.id: _stable(r) for r in rows} == {r.id: _stable(r) for r in serial}
    entries = sorted(p.name for p in (tmp_path / "cache-dask" / "prt").glob("*.npz"))
    assert len(entries) == 2 and entries == sorted(p.name for p in (cache / "prt").glob("*.npz"))
