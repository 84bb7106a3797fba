"""`iblcheck paper`: run the paper's experiments (experiments/paper/registry.py, E1 ... E10 in number
order, or the subset `--only` names) into one report folder.

Everything lands in OUT (default reports/paper): results.jsonl (every compared configuration),
experiments.json (the sections), figures/*.png, index.html and summary.md. `--quick` uses smaller
images, fewer samples and a coarser grid (under 5 minutes here from a cold cache).

Rows are keyed by content: a row already in OUT/results.jsonl is reused, never computed again, so an
interrupted run resumes and a subset run reuses what a full run computed.

A subset run (`only`) keeps what earlier runs left in OUT for the experiments it does not run: their
rows in results.jsonl, and their sections (from experiments.json, when that was written by a run of
the same kind, quick or full), so summary.md and index.html still show every experiment; the subtitle
names the sections that come from an earlier run. A run of every experiment rewrites results.jsonl with
its own rows only (a quick run after a full one, or the reverse, must not mix the two in one report).
"""

from __future__ import annotations

import json
import re
import time
from pathlib import Path
from types import ModuleType

from rich import progress as rp

from experiments.measure.results import RESULTS, folder_lock
from experiments.paper import context as ctx
from experiments.paper import registry
from experiments.paper.context import CommandLine, Context
from experiments.publish import outputs, report
from experiments.publish.report import Section
from experiments.publish.text import one_line
from experiments.runs import dask_cluster
from scenes import InputError

TITLE = "iblcheck paper suite: Gu et al. 2006 against Mitsuba 3"
_SECTION_NAME = re.compile(r"^(E[0-9]+)\b")


def count_steps(experiments: list[ModuleType], quick: bool) -> int:
    """Progress steps of running `experiments`."""
    return sum(m.count_steps(registry.settings_of(m, quick)) for m in experiments)


def run(out: Path, quick: bool = False, only: list[ModuleType] | None = None, workers: int | None = None,
        scheduler: str | None = None, cluster=None, command_line: CommandLine | None = None) -> Path:
    """Run the experiments `only` (None: all of them) into `out` (checked and locked first: one writer per
    folder); returns the path of index.html. `workers` / `scheduler` / `cluster`: references as Dask tasks
    (experiments/runs/dask_cluster.py). `command_line`: the `iblcheck` entry points E6 runs commands
    through."""
    experiments = list(registry.EXPERIMENTS) if only is None else [m for m in registry.EXPERIMENTS if m in only]
    with outputs.Outputs() as plan, folder_lock(plan.folder(out, "--out")):
        plan.folder(out / "figures", "--out")
        if cluster is None and workers is None and scheduler is None:
            return _run(out, quick, experiments, None, command_line)
        with dask_cluster.maybe_cluster(workers, scheduler, cluster) as cl:
            index = _run(out, quick, experiments, cl, command_line)
            print(one_line(cl.summary()))
            return index


def _run(out: Path, quick: bool, experiments: list[ModuleType], cluster, command_line) -> Path:
    t0 = time.perf_counter()
    timings: dict[str, float] = {}
    subset = len(experiments) < len(registry.EXPERIMENTS)
    columns = [rp.TextColumn("[bold]paper"), rp.BarColumn(), rp.MofNCompleteColumn(), rp.TimeElapsedColumn(),
               rp.TextColumn("eta"), rp.TimeRemainingColumn(), rp.TextColumn("{task.description}")]
    with outputs.rich_progress(*columns) as progress:
        task = progress.add_task("", total=count_steps(experiments, quick))
        context = Context(out, ctx.QUICK if quick else ctx.FULL, lambda: progress.advance(task), cluster,
                          command_line)
        before = dict(context.done)
        sections: dict[str, Section] = {}
        for module in experiments:
            name = registry.name(module)
            progress.update(task, description=name)
            t = time.perf_counter()
            sections[name] = module.run(context, registry.settings_of(module, quick))
            timings[name] = time.perf_counter() - t
    run_names = set(sections)
    if subset:  # keep the other experiments' rows
        kept = [r for i, r in before.items() if i not in context.used and r.experiment not in run_names]
        context.store.rewrite([context.done[i] for i in context.used] + kept)
    else:
        context.store.rewrite([context.done[i] for i in context.used])
    earlier, why = earlier_sections(out, quick) if subset else ({}, "")
    earlier = {k: v for k, v in earlier.items() if k not in run_names}
    order = {registry.name(m): m.NUMBER for m in registry.EXPERIMENTS}
    merged = dict(sorted({**earlier, **sections}.items(), key=lambda kv: order.get(kv[0], 1_000)))
    total = time.perf_counter() - t0
    common = context.common
    subtitle = (f"{'quick' if quick else 'full'} suite, {common.size}x{common.size} pixels, references at "
                f"{common.spp} spp; this run ({', '.join(sections) if subset else 'every experiment'}) took "
                f"{total / 60:.1f} min (" + ", ".join(f"{k} {v:.0f} s" for k, v in timings.items())
                + f"), reusing {context.reused} of {len(context.used)} compared configurations already in {RESULTS}")
    if earlier:
        subtitle += f"; {', '.join(earlier)} as an earlier run in this folder left them"
    if why:
        subtitle += f"; {why}"
    outputs.write_text(out / report.SECTIONS, json.dumps({
        "title": TITLE, "subtitle": subtitle, "quick": quick, "seconds": timings, "total_s": total,
        "sections": [{**vars(s), "experiment": k} for k, s in merged.items()]}, indent=1))
    return report.build(out, title=TITLE, sections=list(merged.values()), subtitle=subtitle)


def earlier_sections(out: Path, quick: bool) -> tuple[dict[str, Section], str]:
    """({experiment name: section} saved in out/experiments.json by an earlier run of the same kind,
    quick or full; a note when there are none to keep and why ('' when none were saved)."""
    path = out / report.SECTIONS
    if not path.is_file():
        return {}, ""
    try:
        meta = report.read_sections(path)
    except InputError:
        return {}, f"the other experiments' sections are not shown ({report.SECTIONS} was unreadable)"
    if bool(meta.get("quick")) != quick:
        kind = "full" if quick else "quick"
        return {}, f"the other experiments' sections are not shown (the earlier run was a {kind} one)"
    out_sections = {}
    for d in meta["sections"]:
        match = _SECTION_NAME.match(str(d.get("title", "")))
        key = d.get("experiment") or (match.group(1) if match else None)
        if isinstance(key, str) and registry.find(key) is not None:
            out_sections[registry.name(registry.find(key))] = Section.from_dict(d)
    return out_sections, ""
