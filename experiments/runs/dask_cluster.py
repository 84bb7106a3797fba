"""Sweeps and the paper suite on a Dask cluster (`iblcheck sweep|paper --workers N | --scheduler ADDRESS`).

Without either option nothing here runs and the serial loop of experiments/runs/sweep.py is used.

What is a task and what is not
- Tasks (on the workers): every Mitsuba reference a row needs, both seeds (the reference and the
  noise-floor render); the precomputation of a technique that needs no GL (PRT's transfer vectors,
  numpy + Embree, `precompute_task`, into the PRT cache that the driver's `prepare` then reads, with
  the compute seconds kept in the entry); the paper's quadrature (`quadrature_task`). Their cost is
  almost all of a sweep's.
  A task gets the scene as a dict (the validated TOML tree, `scene_payload`), never a live Mitsuba
  object; the worker validates it again and checks that it resolves to the same content as on the
  driver (a map or mesh file that differs on another machine is an error, not a silent mismatch).
- The driver (this process): the plan, the real-time render of every row and its frame times (one
  GL, the driver's, so that frame times stay comparable), the GL half of the techniques' `prepare`,
  the metrics, the pictures, and every write of `results.jsonl`. Every row records the host and the
  GL renderer that timed it (`host`, `gl_renderer`).
- Frame times on a shared machine: when a worker runs on the driver's host (`--workers N`, or a
  scheduler whose workers include this machine), rows are timed only once no reference task is left
  (`quiet` timing): rendering references beside a timed frame would change the frame time by
  however many workers happen to be busy. With every worker elsewhere, rows are timed as soon as
  their references arrive.

Keys, retries, exactly once
- A reference task's key is `<function>-<reference content id>-s<seed>` (a precomputation's
  `precompute-<PRT cache key>`): content-addressed like the caches, so the rows that share a
  reference (a LOD-bias or face-size axis) share one task,
  and a resubmitted key is the same task. `retries=RETRIES`: a task that raises is tried again
  (possibly elsewhere); a task whose worker dies is rescheduled by the scheduler (up to
  `distributed.scheduler.allowed-failures` deaths, then KilledWorker).
- A row is written once: the driver alone appends to results.jsonl (the folder is locked for the
  run, results.folder_lock) and writes a row id at most once; a row whose reference failed after its
  retries is written with `error` set and no metrics (and is computed again by the next run).
- The driver killed: the rows written so far stay (a half line is cut on read), the references
  finished so far are in the cache; the rerun skips those rows and hits those entries.

The reference cache
- A task renders through groundtruth.pathtracer.reference.render: the worker that renders an entry writes it,
  atomically (temporary file + rename, with the per-key lock), into its cache folder. A local
  cluster's workers get the driver's folder (`IBLCHECK_CACHE` as the driver sees it), so every
  entry is written once, by whoever rendered it, and a later serial command hits it.
- The rendered arrays are also handed back to the driver (the row needs them, and a remote worker's
  cache is not the driver's); the driver stores the entry in its own cache only when it is not there
  yet (another machine's worker rendered it). So the cluster needs no shared file system: a folder
  shared by every machine would also do, but Dr.Jit's kernel cache must never sit on one (below).

Worker processes
- Spawned, never forked (`distributed.worker.multiprocessing-method = "spawn"`): Dr.Jit's LLVM
  backend is not fork-safe and a moderngl context in a parent hangs forked children.
- `WorkerSetup` (a WorkerPlugin) runs in every worker, also one that joins or restarts later:
  it moves Dr.Jit's kernel cache off a network home folder (DRJIT_CACHE_DIR, a local folder), sets
  DRJIT_LIBLLVM_PATH and the Mitsuba variant through groundtruth.pathtracer.variant, sets Dr.Jit's thread count
  on a local cluster (cores / workers), and records what it found and how long it took. The driver
  prints one line per worker; a worker without a usable variant is reported and retired, and no
  usable worker at all is MissingCapability (exit 3). Mitsuba's variant is per thread in some
  versions: every task sets it again in its own thread.
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import time
import warnings
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import dask
from distributed import Client, LocalCluster, as_completed, wait
from distributed.diagnostics.plugin import WorkerPlugin
from rich import progress as rp

import scenes
from experiments.publish import outputs
from experiments.publish.text import one_line
from experiments.runs.rows import content_id, error_row, run_row, short
from groundtruth.exact import quadrature
from groundtruth.pathtracer import reference
from groundtruth.pathtracer import reference_cache as cache
from groundtruth.pathtracer.reference import second_seed
from groundtruth.pathtracer.variant import mitsuba
from realtime.techniques.prt import prt_transfer
from realtime.techniques.prt.prt import transfer_objects
from realtime.techniques.prt.prt_transfer import cached_transfer, transfer_key
from realtime.techniques.prt.settings import effective_settings
from scenes import InputError, MissingCapability
from scenes.model.scene import from_dict

#: how often a task that raises is tried again (worker deaths are counted apart, by the scheduler)
RETRIES = 2
#: seconds the driver waits for a scheduler given with --scheduler
CONNECT_TIMEOUT_S = 10
#: file systems on which Dr.Jit's kernel cache must not be shared by concurrent processes
NETWORK_FS = {"nfs", "nfs4", "cifs", "smb3", "smbfs", "fuse.sshfs", "9p", "lustre", "gpfs", "ceph", "fuse.glusterfs",
              "beegfs", "afs", "fuse.s3fs", "fuse.rclone"}

#: what WorkerSetup found in this (worker) process; None until it ran
_SETUP: dict | None = None


# ----------------------------------------------------------------------------- worker side
def _fs_type(path: str) -> str | None:
    """The file-system type of the mount that holds `path` (from /proc/mounts; None where unknown)."""
    try:
        lines = Path("/proc/mounts").read_text().splitlines()
    except OSError:
        return None
    best, kind = "", None
    path = os.path.realpath(path)
    for line in lines:
        parts = line.split()
        if len(parts) >= 3 and (path == parts[1] or path.startswith(parts[1].rstrip("/") + "/")) \
                and len(parts[1]) >= len(best):
            best, kind = parts[1], parts[2]
    return kind


def _drjit_cache_dir() -> tuple[str | None, str]:
    """Where Dr.Jit will keep its kernel cache in this process, and why. Must run before drjit is
    imported. On a network home folder it is moved to a local folder of this machine."""
    if os.environ.get("DRJIT_CACHE_DIR"):
        return os.environ["DRJIT_CACHE_DIR"], "DRJIT_CACHE_DIR as set"
    home = os.environ.get("HOME")
    if not home:
        return None, "no HOME: Dr.Jit keeps no kernel cache"
    kind = _fs_type(home)
    if kind in NETWORK_FS:
        local = os.path.join("/tmp", f"iblcheck-drjit-{os.getuid()}")
        os.makedirs(local, mode=0o700, exist_ok=True)
        os.environ["DRJIT_CACHE_DIR"] = local
        return local, f"moved off {home} ({kind}: concurrent processes must not share it)"
    return os.path.join(home, ".drjit"), f"local ({kind or 'unknown'} file system)"


def worker_setup(drjit_threads: int | None = None) -> dict:
    """Set up Mitsuba in this process (see the module docstring) and return what was found. Never
    raises: a failure is recorded as `ok = False` with `error`."""
    t0 = time.perf_counter()
    info: dict[str, Any] = {"host": socket.gethostname(), "pid": os.getpid(), "ok": False}
    try:
        info["drjit_cache"], info["drjit_cache_note"] = _drjit_cache_dir()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mi = mitsuba()
        import drjit as dr  # deferred: Dr.Jit comes with Mitsuba, loaded only once its variant is set

        if drjit_threads:
            dr.set_thread_count(int(drjit_threads))
        info.update(ok=True, variant=mi.variant(), mitsuba=mi.__version__, drjit=dr.__version__,
                    libllvm=os.environ.get("DRJIT_LIBLLVM_PATH"), drjit_threads=dr.thread_count(),
                    warnings=[one_line(str(w.message), 200) for w in caught])
    except Exception as exc:  # MissingCapability, a broken install: reported by the driver
        hint = getattr(exc, "hint", "")
        info["error"] = one_line(f"{type(exc).__name__}: {exc}" + (f" ({hint})" if hint else ""), 300)
    info["iblcheck_cache"] = str(cache.cache_dir())
    info["setup_s"] = time.perf_counter() - t0
    return info


def ensure_setup(drjit_threads: int | None = None) -> dict:
    """This process's setup, run now if the plugin has not run yet (a task can reach a worker that
    joined a moment ago)."""
    global _SETUP
    if _SETUP is None:
        _SETUP = worker_setup(drjit_threads)
    return _SETUP


def setup_info() -> dict | None:
    """For `client.run`: what this worker's setup found (None before it ran)."""
    return _SETUP


class WorkerSetup(WorkerPlugin):
    """Mitsuba variant, DRJIT_LIBLLVM_PATH and Dr.Jit's kernel cache and threads, once per worker process
    (also in a worker that joins or is restarted later: the scheduler hands it every plugin)."""

    name = "iblcheck-setup"

    def __init__(self, drjit_threads: int | None = None) -> None:
        self.drjit_threads = drjit_threads

    def setup(self, worker) -> None:
        ensure_setup(self.drjit_threads)


@contextlib.contextmanager
def _cache_env(cache_dir: str | None) -> Iterator[None]:
    """The reference cache folder for one task (a local cluster's workers use the driver's). Workers
    of a local cluster run one task at a time (threads_per_worker = 1)."""
    if cache_dir is None:
        yield
        return
    old = os.environ.get("IBLCHECK_CACHE")
    os.environ["IBLCHECK_CACHE"] = cache_dir
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("IBLCHECK_CACHE", None)
        else:
            os.environ["IBLCHECK_CACHE"] = old


def scene_payload(scene) -> dict:
    """What a worker needs to rebuild `scene`: its validated TOML tree (paths absolute), not a file name
    relative to the driver's working directory and never a live Mitsuba object."""
    base = scene.path if scene.path and not scene.path.startswith("builtin:") else ""
    return {"tree": scene.source, "where": scene.path, "name": scene.name,
            "base_dir": os.path.abspath(os.path.dirname(base)) if base else os.getcwd()}


def scene_from_payload(payload: dict):
    """The scene a worker rebuilds from `scene_payload`'s dict."""
    return from_dict(payload["tree"], payload["where"], Path(payload["base_dir"]), name_default=payload["name"])


def _mitsuba_for_task():
    info = ensure_setup()
    if not info["ok"]:
        raise RuntimeError(f"worker {info['host']} (pid {info['pid']}) has no usable Mitsuba variant: {info['error']}")
    mi = mitsuba()
    if mi.variant() != info["variant"]:  # a variant is per thread in some Mitsuba versions
        mi.set_variant(info["variant"])
    return info


def reference_task(payload: dict, seed: int, expect: str, cache_dir: str | None = None,
                   use_cache: bool = True) -> dict:
    """One Mitsuba reference of a scene at `seed` (a task). Returns {"render": Render, "host", "pid",
    "seconds"}; `expect` is the driver's reference content id of the scene."""
    info = _mitsuba_for_task()
    scene = scene_from_payload(payload)
    got = content_id(scene, reference_only=True)
    if got != expect:
        raise RuntimeError(f"{scene.name}: worker {info['host']} resolves the scene to other content than the "
                           f"driver ({got} != {expect}): its map or mesh files (or the light array made from "
                           "them) differ")
    t0 = time.perf_counter()
    with _cache_env(cache_dir):
        render = reference.render(scene, seed=int(seed), use_cache=use_cache)
    return {"render": render, "host": info["host"], "pid": os.getpid(), "seconds": time.perf_counter() - t0}


def quadrature_task(payload: dict) -> dict:
    """The noise-free quadrature of a scene (a task; numpy only). Returns {"render", "host", "pid", "seconds"}."""
    t0 = time.perf_counter()
    render = quadrature.render(scene_from_payload(payload))
    return {"render": render, "host": socket.gethostname(), "pid": os.getpid(), "seconds": time.perf_counter() - t0}


def prt_settings(scene) -> tuple[int, int, int, bool] | None:
    """(order, rays, bounces, shadowed) of the PRT transfer `scene` precomputes (None: no PRT), as the PRT
    technique derives them (realtime.techniques.prt.settings.effective_settings)."""
    if scene.realtime.diffuse != "prt":
        return None
    s = effective_settings(scene)
    return s.order, s.rays, s.bounces, s.shadowed


def precompute_task(payload: dict, cache_dir: str | None = None) -> dict:
    """The precomputation of a scene's real-time techniques that runs without GL: PRT's transfer vectors
    (numpy + Embree), into the PRT cache (a task). Returns {"arrays", "info", "host", "pid", "seconds"}."""
    scene = scene_from_payload(payload)
    order, rays, bounces, shadowed = prt_settings(scene)
    t0 = time.perf_counter()
    with _cache_env(cache_dir):
        arrays, info = cached_transfer(transfer_objects(scene), order, rays, bounces, shadowed)
    return {"arrays": arrays, "info": info, "host": socket.gethostname(), "pid": os.getpid(),
            "seconds": time.perf_counter() - t0}


def _scheduler_states(keys: list, dask_scheduler=None) -> dict:
    """For `client.run_on_scheduler`: (state, retries left, times suspected of killing a worker) per key."""
    out = {}
    for k in keys:
        ts = dask_scheduler.tasks.get(k)
        if ts is not None:
            out[k] = (ts.state, ts.retries, ts.suspicious)
    return out


# ----------------------------------------------------------------------------- driver side
@dataclass
class TaskStats:
    """What the progress bar shows and the run reports."""

    submitted: int = 0
    done: int = 0
    failed: int = 0
    running: int = 0
    retried: set = field(default_factory=set)  # keys tried more than once
    seconds: list = field(default_factory=list)  # each finished task's own time on its worker
    phases: dict = field(default_factory=dict)  # run_rows: "references" (submit to last task), "rows" (wall s)

    def text(self) -> str:
        return (f"running {self.running} · done {self.done} · failed {self.failed} · "
                f"retried {len(self.retried)}")


class Cluster:
    """A Dask client: a LocalCluster of `workers` spawned processes (one thread each), or the scheduler
    at `scheduler`. A context manager; `setup` holds each worker's WorkerSetup report."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None, retries: int = RETRIES,
                 echo: Callable[[str], None] | None = print) -> None:
        if (workers is None) == (scheduler is None):
            raise InputError("give either --workers N or --scheduler ADDRESS")
        if workers is not None and workers < 1:
            raise InputError(f"--workers {workers}: must be at least 1")
        self.workers, self.scheduler, self.retries = workers, scheduler, retries
        self.echo = echo or (lambda text: None)
        self.client = None
        self._cluster = None
        self._config = None
        self.setup: dict[str, dict] = {}
        self.start_s = 0.0
        self.quiet_timing = True
        self.reference_fn: Callable[..., dict] = reference_task  # tests swap in a slow or failing one
        self.futures: dict[str, Any] = {}  # key -> Future, held while a row needs it
        self.stats = TaskStats()
        self._counted: set[str] = set()

    # -- life cycle ---------------------------------------------------------------------------------
    def __enter__(self) -> Cluster:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def start(self) -> None:
        t0 = time.perf_counter()
        try:
            self._start(t0)
        except BaseException:
            self.close()
            raise

    def _start(self, t0: float) -> None:
        self._config = dask.config.set({"distributed.worker.multiprocessing-method": "spawn",
                                        "distributed.worker.daemon": True})
        threads = None
        if self.scheduler is None:
            # no dashboard; the scheduler's HTTP endpoints on a free local port (not 8787: another run
            # may hold it)
            self._cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True,
                                         host="127.0.0.1", dashboard_address=None, silence_logs=logging.ERROR,
                                         scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})
            self.client = Client(self._cluster)
            threads = max(1, (os.cpu_count() or 1) // self.workers)
        else:
            try:
                self.client = Client(self.scheduler, timeout=CONNECT_TIMEOUT_S)
            except (OSError, TimeoutError) as exc:
                raise InputError(f"--scheduler {self.scheduler}: no Dask scheduler answered within "
                                 f"{CONNECT_TIMEOUT_S} s ({type(exc).__name__})") from None
            try:
                self.client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
            except (OSError, TimeoutError):
                raise MissingCapability(f"no Dask worker is connected to {self.scheduler} (waited "
                                        f"{CONNECT_TIMEOUT_S} s)", f"start `dask worker {self.scheduler}` on the "
                                        "machines that should render") from None
        self.client.register_plugin(WorkerSetup(threads), name="iblcheck-setup")
        self.setup = {addr: info for addr, info in self.client.run(setup_info).items() if info is not None}
        self.start_s = time.perf_counter() - t0
        self._report_setup()

    def close(self) -> None:
        self.futures.clear()
        for obj in (self.client, self._cluster):
            if obj is not None:
                with contextlib.suppress(Exception):
                    obj.close()
        self.client = self._cluster = None
        if self._config is not None:
            self._config.__exit__(None, None, None)
            self._config = None

    def _report_setup(self) -> None:
        here = socket.gethostname()
        bad = {a: i for a, i in self.setup.items() if not i.get("ok")}
        good = {a: i for a, i in self.setup.items() if i.get("ok")}
        self.echo(one_line(f"dask: {len(self.setup)} workers ({'local cluster' if self._cluster else self.scheduler}),"
                           f" started in {self.start_s:.1f} s"))
        for addr, info in sorted(self.setup.items()):
            if info.get("ok"):
                self.echo(one_line(f"  worker {addr} on {info['host']} (pid {info['pid']}): {info['variant']}, "
                                   f"libLLVM {info.get('libllvm') or '-'}, {info['drjit_threads']} Dr.Jit threads, "
                                   f"kernel cache {info['drjit_cache_note']}, set-up {info['setup_s']:.2f} s"
                                   + "".join(f"; warning: {w}" for w in info.get("warnings", []))))
            else:
                self.echo(one_line(f"  worker {addr} on {info['host']} (pid {info['pid']}): UNUSABLE, retired: "
                                   f"{info.get('error')}"))
        if bad:
            with contextlib.suppress(Exception):
                self.client.retire_workers(workers=list(bad), close_workers=True)
        if not good:
            raise MissingCapability("no Dask worker has a usable Mitsuba variant" +
                                    (f" ({next(iter(bad.values())).get('error')})" if bad else " (no workers)"),
                                    "install libllvm19 on the workers or set IBLCHECK_VARIANT=scalar_rgb")
        variants = sorted({i["variant"] for i in good.values()})
        if len(variants) > 1:
            self.echo(one_line(f"warning: the workers use different Mitsuba variants ({', '.join(variants)}); "
                               "their references are not interchangeable (the cache keys them apart)"))
        self.quiet_timing = any(i["host"] == here for i in self.setup.values())

    # -- tasks -------------------------------------------------------------------------------------
    def reference_keys(self, scene, ref_id: str | None = None) -> list[tuple[str, int]]:
        """[(task key, seed)] of the two references of `scene` (the seed and the noise-floor seed)."""
        ref_id = ref_id or content_id(scene, reference_only=True)
        seed = int(scene.reference.seed)
        name = getattr(self.reference_fn, "__name__", "reference")
        return [(f"{name}-{ref_id}-s{s}", s) for s in (seed, second_seed(seed))]

    def submit_references(self, scene) -> list[str]:
        """Submit the scene's two reference tasks (a key already held is not submitted again)."""
        ref_id = content_id(scene, reference_only=True)
        keys, payload, cache = [], None, self._local_cache()
        for key, seed in self.reference_keys(scene, ref_id):
            if key not in self.futures:
                payload = payload or scene_payload(scene)
                self.futures[key] = self.client.submit(self.reference_fn, payload, seed, ref_id, cache,
                                                       key=key, retries=self.retries, pure=False)
                self.stats.submitted += 1
            keys.append(key)
        return keys

    def submit_precompute(self, scene) -> str | None:
        """Submit the scene's PRT transfer as a task (None: the scene has no CPU precomputation)."""
        settings = prt_settings(scene)
        if settings is None:
            return None
        key = f"precompute-{transfer_key(transfer_objects(scene), *settings)}"
        if key not in self.futures:
            self.futures[key] = self.client.submit(precompute_task, scene_payload(scene), self._local_cache(),
                                                   key=key, retries=self.retries, pure=False)
            self.stats.submitted += 1
        return key

    def submit_row(self, scene) -> list[str]:
        """Every task a row of `scene` needs: its two references, then its precomputation if it has one."""
        keys = self.submit_references(scene)
        pre = self.submit_precompute(scene)
        return keys + ([pre] if pre else [])

    def submit_quadrature(self, scene) -> str:
        """Submit the scene's noise-free quadrature as a task (a key already held is not submitted again)."""
        key = f"quadrature-{content_id(scene, reference_only=True)}"
        if key not in self.futures:
            self.futures[key] = self.client.submit(quadrature_task, scene_payload(scene), key=key,
                                                   retries=self.retries, pure=False)
            self.stats.submitted += 1
        return key

    def _local_cache(self) -> str | None:
        """The driver's cache folder for a local cluster's workers (None: workers use their own)."""
        if self._cluster is None:
            return None
        return str(cache.cache_dir().absolute())

    def quadrature(self, scene) -> tuple:
        """(the quadrature Render of `scene`, its seconds on the worker that ran it), as a task."""
        key = self.submit_quadrature(scene)
        try:
            res = self.futures[key].result()
        except Exception:
            self.stats.failed += 1
            raise
        finally:
            self.release([key])
        self._count_finished(key, res)
        return res["render"], res["seconds"]

    def release(self, keys) -> None:
        """Drop the driver's hold on finished tasks (their results leave the workers' memory); their retry
        counts are read from the scheduler first."""
        keys = [k for k in keys if k in self.futures]
        self.poll(keys, running=False)
        for k in keys:
            self.futures.pop(k, None)

    def references(self, scene) -> tuple:
        """The scene's two reference Renders, rendered on the cluster (both seeds at once, and its PRT
        transfer beside them, into the driver's cache); raises the task's error after its retries. For
        the paper suite's rows."""
        keys = self.submit_row(scene)
        wait([self.futures[k] for k in keys])
        out = []
        for k in keys:
            fut = self.futures[k]
            if fut.status != "finished":
                self.stats.failed += 1
                raise RuntimeError(f"{scene.name}: task {k} failed: {describe_error(fut)}")
            res = fut.result()
            self._count_finished(k, res)
            keep_in_driver_cache(res)
            if "render" in res:
                out.append(res["render"])
        self.release(keys)
        return tuple(out)

    def wait_idle(self) -> None:
        """Wait until every task held has finished (before timing frames on a shared host)."""
        if self.futures:
            wait(list(self.futures.values()))

    def _count_finished(self, key: str, res: dict) -> None:
        if key not in self._counted:
            self._counted.add(key)
            self.stats.done += 1
            self.stats.seconds.append(res["seconds"])

    def poll(self, keys: list[str], running: bool = True) -> None:
        """Refresh the running and retried counts from the scheduler (`running`: recount the running tasks
        among `keys`)."""
        if not keys:
            if running:
                self.stats.running = 0
            return
        try:
            states = self.client.run_on_scheduler(_scheduler_states, keys)
        except Exception:  # the scheduler busy or gone: keep the last counts
            return
        if running:
            self.stats.running = sum(1 for s, _, _ in states.values() if s == "processing")
        for k, (_, left, suspicious) in states.items():
            if left < self.retries or suspicious > 0:
                self.stats.retried.add(k)

    def summary(self) -> str:
        """One line: tasks, retries, failures, task time against worker set-up time."""
        s = self.stats
        setup = [i["setup_s"] for i in self.setup.values() if "setup_s" in i]
        mean_task = sum(s.seconds) / len(s.seconds) if s.seconds else None
        mean_setup = sum(setup) / len(setup) if setup else None
        text = (f"dask: {s.done} tasks done on {len(self.setup)} workers, {len(s.retried)} retried, {s.failed} failed")
        if mean_task is not None:
            text += f"; mean task {mean_task:.2f} s ({sum(s.seconds):.1f} s in all)"
        if mean_setup is not None:
            text += f"; worker set-up {mean_setup:.2f} s each"
            if s.seconds:
                text += f" ({100 * mean_setup * len(setup) / max(sum(s.seconds), 1e-9):.0f}% of the task time)"
        return text


def describe_error(fut) -> str:
    """`Type: message` of a failed future (KilledWorker when its workers kept dying)."""
    try:
        exc = fut.exception()
    except Exception as e:  # a cancelled or lost future
        exc = e
    return one_line(f"{type(exc).__name__}: {exc}", 400)


def keep_in_driver_cache(res: dict) -> None:
    """Store a handed-back reference (or PRT transfer) in the driver's cache when it is not there (a worker
    on another machine made it; on one machine the worker already wrote this very file)."""
    if "arrays" in res:  # a PRT transfer: the entry as realtime/techniques/prt/prt_transfer.py writes it
        info, folder = res["info"], cache.cache_dir() / "prt"
        if not (folder / f"{info['key']}.npz").exists():
            prt_transfer._store(folder, info["key"], res["arrays"], {
                "rays_traced": info["rays_traced"], "vertices": info["vertices"], "seconds": info["compute_seconds"],
                "version": prt_transfer.TRANSFER_VERSION})
        return
    if "render" not in res:
        return
    render = res["render"]
    key = render.meta.get("key")
    if not key or (cache.cache_dir() / f"{key}.npz").exists():
        return
    meta = {k: v for k, v in render.meta.items() if k != "cache"}
    cache.store(key, render.rgb, render.mask, meta)


@contextlib.contextmanager
def maybe_cluster(workers: int | None, scheduler: str | None, cluster: Cluster | None = None,
                  echo: Callable[[str], None] | None = print) -> Iterator[Cluster | None]:
    """`cluster` if given; else a Cluster for --workers / --scheduler; else None (the serial path)."""
    if cluster is not None:
        yield cluster
    elif workers is None and scheduler is None:
        yield None
    else:
        with Cluster(workers, scheduler, echo=echo) as c:
            yield c


# ----------------------------------------------------------------------------- the sweep driver loop
@dataclass
class _Row:
    spec: str
    overrides: dict
    keys: list[str]


def run_rows(cluster: Cluster, out_dir: Path, store, todo: list[tuple[str, dict, str]], done: int,
             echo: Callable[[str], None] | None = print) -> list:
    """The sweep on `cluster`: submit every row's references, then, as they complete, render each row's
    real-time part here and append the row (see the module docstring). Returns the rows written."""
    try:
        return _run_rows(cluster, out_dir, store, todo, done, echo)
    finally:  # an interrupted run leaves no task held (a cluster given by the caller lives on)
        cluster.futures.clear()


def _run_rows(cluster: Cluster, out_dir: Path, store, todo: list[tuple[str, dict, str]], done: int,
              echo: Callable[[str], None] | None) -> list:
    t_start = time.perf_counter()
    rows: dict[str, _Row] = {}
    users: dict[str, list[str]] = {}
    for spec, ov, rid in todo:
        keys = cluster.submit_row(scenes.load(spec).with_overrides(ov))
        rows[rid] = _Row(spec, ov, keys)
        for k in keys:
            users.setdefault(k, []).append(rid)
    unique = list(dict.fromkeys(k for r in rows.values() for k in r.keys))
    ac = as_completed([cluster.futures[k] for k in unique])
    finished: dict[str, dict] = {}  # key -> task result (held until no row needs it)
    failed: dict[str, str] = {}
    ready: deque[str] = deque()
    written: list = []
    ids_written: set[str] = set()

    def settle(rid: str) -> None:
        r = rows[rid]
        if all(k in finished or k in failed for k in r.keys):
            errors = [f"task {k} failed after {cluster.retries + 1} tries: {failed[k]}"
                      for k in r.keys if k in failed]
            if errors:
                write(rid, error_row(r.spec, r.overrides, rid, "; ".join(errors)))
            else:
                ready.append(rid)

    def write(rid: str, row) -> None:
        if rid in ids_written:  # never twice (a key's completion is seen once, but be sure)
            return
        store.append(row)
        ids_written.add(rid)
        written.append(row)
        progress.advance(row_task)
        for k in rows[rid].keys:
            users[k].remove(rid)
            if not users[k]:
                finished.pop(k, None)
                cluster.release([k])

    columns = [rp.TextColumn("[bold]{task.fields[label]}"), rp.BarColumn(), rp.MofNCompleteColumn(),
               rp.TimeElapsedColumn(), rp.TextColumn("{task.description}", markup=False)]
    last_poll = 0.0
    with outputs.rich_progress(*columns, transient=False) as progress:
        ref_task = progress.add_task("", total=len(unique), label="tasks")
        row_task = progress.add_task("", total=done + len(todo), completed=done, label="rows")
        while len(ids_written) < len(rows):
            batch = ac.next_batch(block=False) if not ac.is_empty() else []
            if batch and ac.is_empty():
                cluster.stats.phases["references"] = time.perf_counter() - t_start
            for fut in batch:
                key = fut.key
                if fut.status == "finished":
                    res = fut.result()
                    cluster._count_finished(key, res)
                    keep_in_driver_cache(res)
                    finished[key] = res
                else:
                    failed[key] = describe_error(fut)
                    cluster.stats.failed += 1
                progress.advance(ref_task)
                for rid in list(users.get(key, [])):
                    settle(rid)
            if ready and (not cluster.quiet_timing or ac.is_empty()):
                rid = ready.popleft()
                r = rows[rid]
                progress.update(row_task, description=one_line(f"{r.spec} {short(r.overrides)}", 100))
                try:
                    refs = tuple(finished[k]["render"] for k in r.keys[:2])
                    row = run_row(out_dir, r.spec, r.overrides, references=refs)
                except MissingCapability:
                    raise
                except Exception as exc:  # the row's real-time part failed: a row with the error
                    row = error_row(r.spec, r.overrides, rid, f"real-time part failed: {type(exc).__name__}: {exc}")
                write(rid, row)
                continue
            now = time.perf_counter()
            if now - last_poll > 0.5:
                cluster.poll([k for k in cluster.futures if k not in finished and k not in failed])
                last_poll = now
                progress.update(ref_task, description=cluster.stats.text())
            if not batch:
                time.sleep(0.05)
        cluster.poll([])
        progress.update(ref_task, description=cluster.stats.text())
    cluster.stats.phases["rows"] = time.perf_counter() - t_start
    if echo:
        echo(one_line(cluster.summary()))
    return written
