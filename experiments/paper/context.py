"""What every experiment of the paper suite is handed: the `Context` (output folder, the resumable row
runner over results.jsonl, the progress callback, the Dask cluster, the command line) and the settings all
experiments share (`Common`: image size, reference spp, timed frames).

An experiment module (experiments/paper/eNN_<subject>.py) reads nothing else from the suite; see
experiments/paper/registry.py for the shape of such a module.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import groundtruth
import realtime
import scenes
from experiments.measure import metrics
from experiments.measure.results import ResultRow, store_in
from experiments.publish import images
from experiments.runs.rows import row_id, run_row, with_equal_quality
from groundtruth.exact import quadrature
from scenes.model.render import Render
from scenes.model.scene import Scene


@dataclass(frozen=True)
class Common:
    """Settings every experiment's rows start from (`Context.base`)."""

    size: int  # image width and height (pixels)
    spp: int  # reference samples per pixel
    frames: int  # timed real-time frames per row


QUICK = Common(size=96, spp=256, frames=10)
FULL = Common(size=192, spp=1024, frames=30)


@dataclass(frozen=True)
class CommandLine:
    """The `iblcheck` entry points, handed down by experiments/cli (E6 runs hostile command lines through
    them; the paper layer never imports the command line's package)."""

    main: Callable[[list[str]], int]  # argv -> exit code
    run_command: Callable[[argparse.Namespace], int]  # a parsed command -> exit code


class Context:
    """The paper suite's run: rows keyed by content in `out`/results.jsonl, computed once and reused
    afterwards (also across experiments and across interrupted runs)."""

    def __init__(self, out: Path, common: Common, progress: Callable[[], None], cluster=None,
                 command_line: CommandLine | None = None):
        self.out, self.common, self.progress = Path(out), common, progress
        self.cluster = cluster  # experiments.runs.dask_cluster.Cluster: references as Dask tasks (None: here)
        self.command_line = command_line
        self.store = store_in(self.out)
        self.done: dict[str, ResultRow] = {r.id: r for r in self.store.read()}
        self.used: list[str] = []  # ids of the rows this run asked for, in order
        self.reused = 0  # rows found in results.jsonl from an interrupted or earlier run
        (self.out / "figures").mkdir(parents=True, exist_ok=True)

    def base(self) -> dict:
        """The overrides every row starts from."""
        return {"camera.width": self.common.size, "camera.height": self.common.size,
                "reference.spp": self.common.spp, "realtime.timing_frames": self.common.frames,
                "realtime.warmup_frames": 3}

    def row(self, spec: str, overrides: dict, experiment: str, curve=None) -> ResultRow:
        """One compared configuration (base() + `overrides`), resumable through results.jsonl; advances
        the progress bar by one. With `curve` (the path tracer's spp ladder) the row gets its time to
        equal quality."""
        ov = {**self.base(), **overrides}
        rid = row_id(spec, ov)
        if rid not in self.done:
            refs = None
            if self.cluster is not None:  # both seeds at once on the workers; frames timed here
                refs = self.cluster.references(scenes.load(spec).with_overrides(ov))
            self.done[rid] = run_row(self.out, spec, ov, experiment, convergence_curve=curve, references=refs)
            self.store.append(self.done[rid])
        elif rid not in self.used:
            self.reused += 1
        if curve is not None and self.done[rid].equal_quality is None:
            # the same configuration measured by another experiment (rows are keyed by content): add
            # the path tracer's time to its quality from this curve, without rendering it again
            self.done[rid] = with_equal_quality(self.done[rid], curve)
            self.store.rewrite(list(self.done.values()))
        if rid not in self.used:
            self.used.append(rid)
        self.progress()
        return self.done[rid]

    def replace_row(self, row: ResultRow) -> None:
        """Store a row again with more measurements (same id), atomically."""
        self.done[row.id] = row
        self.store.rewrite(list(self.done.values()))

    def quadrature(self, scene: Scene) -> tuple[Render, float]:
        """(the noise-free quadrature Render of `scene`, its seconds): a Dask task with a cluster (timed
        on the worker that ran it), else computed here."""
        if self.cluster is not None:
            return self.cluster.quadrature(scene)
        t0 = time.perf_counter()
        return quadrature.render(scene), time.perf_counter() - t0

    def prefetch(self, items: list[tuple[str, dict]], quadratures: tuple[str, ...] = ()) -> None:
        """With a cluster: submit the references of these (spec, overrides) now, so that they render in
        parallel; `row` then finds them (a miss costs parallelism, never correctness). On a host shared
        with the workers, wait for them before any frame is timed. Without a cluster: nothing."""
        if self.cluster is None:
            return
        for spec, ov in items:
            self.cluster.submit_references(scenes.load(spec).with_overrides({**self.base(), **ov}))
        for spec in quadratures:
            self.cluster.submit_quadrature(scenes.load(spec).with_overrides(self.base()))
        if self.cluster.quiet_timing:
            self.cluster.wait_idle()

    @staticmethod
    def scene_of(row: ResultRow) -> Scene:
        """The scene of a compared row, with one timed frame (the image does not depend on how many)."""
        return scenes.load(row.spec).with_overrides({**row.overrides, "realtime.timing_frames": 1,
                                                     "realtime.warmup_frames": 0})

    def image_of(self, row: ResultRow) -> tuple[Scene, Render]:
        """(scene, real-time Render) of a compared row: the render the row kept (its measured.npz,
        experiments.publish.images.load_measured), not rendered again. A row written before rows kept
        it is rendered again with one frame."""
        sc = self.scene_of(row)
        kept = images.load_measured(self.out, row)
        return sc, (kept.test if kept is not None else realtime.render(sc))

    def error_of(self, row: ResultRow) -> tuple[Scene, np.ndarray, np.ndarray]:
        """(scene, common mask, display error map) of a compared row: |realtime - reference| of the
        display values, mean over RGB, as the row measured it (its measured.npz); recomputed from
        `image_of` and the cached reference for a row written before rows kept it."""
        kept = images.load_measured(self.out, row)
        if kept is not None:
            return self.scene_of(row), kept.mask, kept.error
        sc, test = self.image_of(row)
        ref = self.reference_of(sc)  # cached by the row
        err = np.abs(metrics.display(sc, test.rgb) - metrics.display(sc, ref.rgb)).mean(-1)
        return sc, metrics.common_mask(test.mask, ref.mask), err

    @staticmethod
    def reference_of(scene: Scene) -> Render:
        """The path-traced reference of `scene` (from the cache its row filled)."""
        return groundtruth.render(scene)
