"""The `iblcheck` command line (docs/contract.md, section 6).

Exit codes (each keeps one meaning, so a crashed CI gate never reads as a failed one):

    0    success
    1    a gate failed (only ever that)
    2    bad input, usage or an unusable output path: one `error: ...` line on stderr, no traceback
    3    the machine lacks something (OpenGL, a Mitsuba variant, memory): a line saying what
    4    an internal error (a bug): one `error: internal error ...` line; `--debug` adds the traceback
    130  interrupted (Ctrl-C): a sweep or paper run resumes where it stopped when rerun

Every line printed about user input goes through experiments/publish/text.py (no control characters,
bounded length).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import sys
import traceback
import warnings
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

from experiments.cli import (
    compare_image_cmd,
    diagnose_cmd,
    export_cmd,
    image_manifest_cmd,
    render_cmd,
    voxel_storage_cmd,
)
from experiments.cli.inputs import (
    UsageError,
    gate_options,
    gate_outputs_are_no_inputs,
    load_scene,
    parse_axis,
    parse_list,
    parse_sets,
)
from experiments.measure import engine_image
from experiments.measure.results import folder_lock, store_in
from experiments.paper import registry
from experiments.paper import suite as paper
from experiments.paper.context import CommandLine
from experiments.publish import outputs, report
from experiments.publish.text import comparison_table, one_line
from experiments.runs import gate, sweep
from experiments.runs.rows import measured_row
from scenes import InputError, MissingCapability
from scenes.model import technique_registry
from scenes.model.scene import SCHEMA

EXIT_OK, EXIT_GATE_FAILED, EXIT_BAD_INPUT, EXIT_MISSING, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 1, 2, 3, 4, 130


#: `iblcheck sweep`'s default grid
DEFAULT_FACE_SIZES, DEFAULT_LOD_BIASES = "8,16,32,64", "-1,0,1,2"


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # argparse's own errors: one line, exit 2
        hint = "; iblcheck --help lists the commands" if message.endswith("required: command") else ""
        print(f"error: {one_line(message)}{hint}", file=sys.stderr)
        raise SystemExit(EXIT_BAD_INPUT)


def threshold(key: str):
    """An argparse type for a gate threshold: a finite number in the range of the scene's [gate] key."""
    check, allowed = SCHEMA["gate"][key]

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = None
        if value is None or check(value) is None:
            raise argparse.ArgumentTypeError(f"{text!r}: must be {allowed}")
        return value

    return parse


def tolerance(flag: str, positive: bool = False):
    """An argparse type for a baseline tolerance: a finite number >= 0 (> 0 with `positive`)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = None
        if value is None or not math.isfinite(value) or value < 0 or (positive and value == 0):
            raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number {'> 0' if positive else '>= 0'}")
        return value

    return parse


def set_help(scope: str = "") -> str:
    """The --set option's help, shared by the commands that take it (`scope`: " for every row", ...)."""
    return (f"override a scene key{scope}, e.g. --set camera.width=64 --set reference.spp=64 (repeatable; a path "
            "such as environment.map is relative to the working directory, a scene file's relative to the file)")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="iblcheck", description="Validate real-time environment lighting against path-traced references.",
                epilog="exit codes: 0 success, 1 a gate failed, 2 bad input or output path, 3 the machine lacks "
                       "something, 4 internal error (--debug shows the traceback), 130 interrupted")
    p.add_argument("--debug", action="store_true", help="on an internal error, print the traceback (any position)")
    p.add_argument("--version", action="version", version=f"iblcheck {gate.iblcheck_version()}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    r = sub.add_parser("render", help="render one scene with one renderer, write EXR + PNG")
    r.add_argument("scene", help="scene file or builtin:NAME")
    r.add_argument("--renderer", choices=["realtime", "reference", "quadrature"], default="realtime")
    r.add_argument("--set", action="append", metavar="K=V", help=set_help())
    r.add_argument("-o", "--out", default=None, help="output .exr path (a .png is written beside it); default: "
                   "SLUG-RENDERER.exr in the working directory, SLUG the scene name's file-safe form")
    r.add_argument("--sanitize", action="store_true", help="replace NaN/Inf/negative environment pixels by 0")
    r.set_defaults(func=_cmd_render)

    c = sub.add_parser("compare", help="real-time vs reference metrics for one scene")
    c.add_argument("scene", help="scene file or builtin:NAME")
    c.add_argument("--set", action="append", metavar="K=V", help=set_help())
    c.add_argument("--json", action="store_true", help="print the metrics and timings as one JSON object")
    c.add_argument("--sanitize", action="store_true", help="replace NaN/Inf/negative environment pixels by 0")
    c.add_argument("--image", metavar="FILE", help="score this engine's image instead of iblcheck's real-time render")
    c.add_argument("--image-encoding", choices=["linear", "srgb"], help="linear radiance (EXR/PFM/HDR, the default "
                   "for those) or tone-mapped sRGB (PNG/JPEG: must be named, with --tonemap)")
    c.add_argument("--tonemap", choices=list(engine_image.TONEMAPS),
                   help="the operator the engine applied (srgb); scene: the scene's own display transform, what "
                        "the PNG of `iblcheck render` holds")
    c.add_argument("--exposure", type=tolerance("--exposure", positive=True),
                   help="the engine's exposure (srgb; 1 with --tonemap scene)")
    c.add_argument("--report", metavar="DIR", help="also write an HTML report of the comparison into DIR "
                   "(index.html with the image viewer; the row is added to DIR/results.jsonl)")
    c.set_defaults(func=_cmd_compare)

    s = sub.add_parser("sweep", help="metrics and timings across face sizes and LOD biases")
    s.add_argument("scenes", nargs="*", help="scene files or builtin:NAME")
    s.add_argument("--images", metavar="MANIFEST", help="append one row per engine image the TOML/JSON manifest "
                   "lists (scene, image, encoding, tonemap, exposure, label) instead of sweeping")
    s.add_argument("--face-sizes", help=f"comma-separated face sizes (default {DEFAULT_FACE_SIZES})")
    s.add_argument("--lod-biases", help=f"comma-separated LOD biases (default {DEFAULT_LOD_BIASES})")
    s.add_argument("--exponents", help="comma-separated Phong exponents (glossy scenes only)")
    s.add_argument("--f0s", help="comma-separated f0 values (blend scenes only)")
    s.add_argument("--envs", help="comma-separated environments (builtin:NAME or files)")
    s.add_argument("--lod-mappings", help="comma-separated: paper, mcguire (glossy scenes only)")
    s.add_argument("--axis", action="append", metavar="KEY=V1,V2", default=[],
                   help="sweep any scene key, e.g. --axis realtime.glossy=box,prefiltered (repeatable); a "
                        "technique's own keys vary only where that technique runs")
    s.add_argument("--technique-axes", action="store_true",
                   help="also sweep every technique of each scene's effects with the parameters it declares worth "
                        "sweeping (SH order and window, irradiance-map sizes, LOD bias and mapping, samples)")
    s.add_argument("--set", action="append", metavar="K=V", help=set_help(" for every row"))
    s.add_argument("--out", default="reports/sweep")
    add_cluster_options(s)
    s.set_defaults(func=_cmd_sweep)

    g = sub.add_parser("gate", help="CI image-quality gate (exit 1 on failure)")
    g.add_argument("scenes", nargs="*", help="scene files or builtin:NAME")
    g.add_argument("--images", metavar="MANIFEST", help="gate each engine image the TOML/JSON manifest lists "
                   "against its scene's reference (baseline key: scene + label)")
    for key, metavar, fails in (("min_psnr", "DB", "PSNR (dB, tone-mapped sRGB) is lower"),
                                ("min_ssim", "X", "SSIM (-1 to 1) is lower"),
                                ("max_flip", "X", "mean FLIP (0 to 1) is higher")):
        g.add_argument("--" + key.replace("_", "-"), type=threshold(key), metavar=metavar,
                       help=f"fail a scene whose {fails}; a scene's [gate] table can set it")
    g.add_argument("--junit", metavar="FILE", help="write JUnit XML here (one test case per scene)")
    g.add_argument("--markdown", metavar="FILE", help="write a short Markdown table here (for a pull-request comment)")
    g.add_argument("--baseline", metavar="FILE", help="fail when a scene got worse than its record in FILE "
                   "(beyond the reference's noise; see --tolerance-*) or is not in it")
    g.add_argument("--write-baseline", metavar="FILE", help="record every scene's metrics, timings and identity "
                   "in FILE (JSON)")
    g.add_argument("--tolerance-db", type=tolerance("--tolerance-db"), metavar="DB",
                   help="with --baseline: the PSNR drop allowed, instead of the noise-aware rule")
    g.add_argument("--tolerance-ssim", type=tolerance("--tolerance-ssim"), metavar="X",
                   help="with --baseline: the SSIM drop allowed, instead of the noise-aware rule")
    g.add_argument("--tolerance-flip", type=tolerance("--tolerance-flip"), metavar="X",
                   help="with --baseline: the FLIP rise allowed, instead of the noise-aware rule")
    g.add_argument("--max-time-ratio", type=tolerance("--max-time-ratio", positive=True), metavar="R",
                   help="with --baseline: fail when the frame time exceeds R times the baseline's "
                        "(reported, never failed, without it)")
    g.add_argument("--set", action="append", metavar="K=V", help=set_help(" for every scene"))
    g.add_argument("--report", metavar="DIR", help="also write an HTML report of the gated scenes into DIR "
                   "(index.html with the image viewer; their rows are added to DIR/results.jsonl)")
    g.set_defaults(func=_cmd_gate)

    rep = sub.add_parser("report", help="regenerate DIR/index.html from DIR/results.jsonl")
    rep.add_argument("dir", help="a folder a sweep, gate --report or compare --report wrote")
    rep.set_defaults(func=_cmd_report)

    export_cmd.add_parser(sub)
    sub.choices["export"].set_defaults(func=_cmd_export)

    diagnose_cmd.add_parser(sub)
    sub.choices["diagnose"].set_defaults(func=_cmd_diagnose)

    voxel_storage_cmd.add_parser(sub)

    pa = sub.add_parser("paper", help="run the paper-style experiment suite (the main job)",
                        description="Run the paper's experiments E1 ... E12 in number order into OUT. Rows already "
                                    "in OUT/results.jsonl are reused, never computed again (an interrupted run "
                                    "resumes).")
    pa.add_argument("--out", default="reports/paper")
    pa.add_argument("--quick", action="store_true")
    pa.add_argument("--only", type=experiment_list, metavar="E8,E10",
                    help="run only these experiments (comma-separated, any case, E08 = E8; valid: "
                         f"{', '.join(registry.names())}). The others' rows stay in OUT/results.jsonl and their "
                         "sections in summary.md and index.html as an earlier run of the same kind (quick or "
                         "full) left them; the page's subtitle names them (after a run of the other kind they "
                         "are left out, and it says so)")
    add_cluster_options(pa)
    pa.set_defaults(func=_cmd_paper)
    return p


def experiment_list(text: str) -> list[ModuleType]:
    """An argparse type for `--only`: comma-separated experiment names -> their modules, in number order."""
    names = [x for x in text.split(",") if x.strip()]
    if not names:
        raise argparse.ArgumentTypeError(f"{text!r}: name at least one experiment ({', '.join(registry.names())})")
    try:
        return registry.select(names)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _workers(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: must be a whole number of worker processes, at least 1")
    return n


def add_cluster_options(parser: argparse.ArgumentParser) -> None:
    """`--workers N` | `--scheduler ADDRESS`: references on a Dask cluster (experiments/runs/dask_cluster.py)."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--workers", type=_workers, metavar="N",
                       help="render the references on a local Dask cluster of N worker processes (real-time "
                            "renders and their frame times stay in this process)")
    group.add_argument("--scheduler", metavar="ADDRESS",
                       help="render the references on a running Dask cluster (`dask scheduler`, `dask worker`), "
                            "e.g. tcp://10.0.0.5:8786")


def _cmd_render(args: argparse.Namespace) -> int:
    return render_cmd.run(args)


def _cmd_export(args: argparse.Namespace) -> int:
    return export_cmd.run(args)


def _cmd_diagnose(args: argparse.Namespace) -> int:
    return diagnose_cmd.run(args)


def _cmd_compare(args: argparse.Namespace) -> int:
    if args.image:
        if args.report:
            raise UsageError("--report: not with --image yet (a report holds iblcheck's own renders)")
        return compare_image_cmd.run(args)
    given = [flag for flag, value in (("--image-encoding", args.image_encoding), ("--tonemap", args.tonemap),
                                      ("--exposure", args.exposure)) if value is not None]
    if given:
        raise UsageError(f"{', '.join(given)}: only with --image FILE (they say how an engine's image is encoded)")
    scene = load_scene(args.scene, args.set, args.sanitize)
    with outputs.Outputs() as plan, _report_folder(plan, args.report) as folder:
        with outputs.progress("compare", 4) as step:
            measured = gate.measure(scene, step, noise=False)
        result = measured.metrics
        if folder is not None:
            overrides = {**parse_sets(args.set), **({"environment.sanitize": True} if args.sanitize else {})}
            pair = measured.pair
            _write_report(folder, [measured_row(folder, args.scene, overrides, scene, result, pair.measurement,
                                                pair.test, pair.reference, pair.reference2)], "iblcheck compare")
    # an empty comparison (no covered or lit pixel) was a `warning:` line of measure_pair's
    print(json.dumps(result, allow_nan=False) if args.json else comparison_table([result]))
    return EXIT_OK


@contextlib.contextmanager
def _report_folder(plan: outputs.Outputs, path: str | None) -> Iterator[Path | None]:
    """The folder of `--report DIR`, checked before anything renders and locked while the command runs
    (None without the option)."""
    if path is None:
        yield None
        return
    folder = plan.folder(path, "--report")
    for name in ("index.html", "summary.md", sweep.RESULTS):
        plan.file(folder / name, "--report")
    with folder_lock(folder, "choose another --report folder"):
        yield folder


def _write_report(folder: Path, new_rows: list, title: str) -> None:
    """`new_rows` into folder/results.jsonl (replacing rows of the same ids: the same scene measured
    again) and the report of all its rows (experiments/publish/report.py, with the viewer)."""
    store = store_in(folder)
    ids = {r.id for r in new_rows}
    store.rewrite([r for r in store.read() if r.id not in ids] + list(new_rows))
    report.build(folder, title=title)


def _warn_broken_plugins() -> None:
    """One `warning:` line per technique plugin that could not be registered, for the commands that list
    every technique (`sweep --technique-axes`, the paper's E7): without it they would leave it out
    silently. (A scene that chooses a broken plugin gets its error line instead.)"""
    for b in technique_registry.broken():
        warnings.warn(f"{b.error}; it is left out", PluginWarning, stacklevel=2)


def _cmd_sweep(args: argparse.Namespace) -> int:
    if args.images or not args.scenes:
        return image_manifest_cmd.sweep_images(args)
    if args.technique_axes:
        _warn_broken_plugins()
    faces = DEFAULT_FACE_SIZES if args.face_sizes is None else args.face_sizes
    biases = DEFAULT_LOD_BIASES if args.lod_biases is None else args.lod_biases
    axes = sweep.Axes(face_sizes=parse_list(faces, int, "--face-sizes"),
                      lod_biases=parse_list(biases, float, "--lod-biases"),
                      exponents=parse_list(args.exponents, float, "--exponents"),
                      f0s=parse_list(args.f0s, float, "--f0s"), envs=parse_list(args.envs, str, "--envs"),
                      lod_mappings=parse_list(args.lod_mappings, str, "--lod-mappings"),
                      extra=[parse_axis(a) for a in args.axis], technique_axes=args.technique_axes)
    rows = sweep.run(args.scenes, axes, Path(args.out), parse_sets(args.set), workers=args.workers,
                     scheduler=args.scheduler)
    print(one_line(f"{len(rows)} rows in {Path(args.out) / sweep.RESULTS}; report: {Path(args.out) / 'index.html'}"))
    return EXIT_OK


def _cmd_gate(args: argparse.Namespace) -> int:
    if args.images and args.report:
        raise UsageError("--report: not with --images yet (a report holds iblcheck's own renders)")
    if args.images or not args.scenes:
        return image_manifest_cmd.gate_images(args)
    cli, tolerances = gate_options(args)
    with outputs.Outputs() as plan:
        baseline = gate.read_baseline(args.baseline) if args.baseline else None
        loaded = gate.load(args.scenes, cli, parse_sets(args.set),
                           thresholds_required=not (args.baseline or args.write_baseline))
        junit = plan.file(args.junit, "--junit") if args.junit else None
        md = plan.file(args.markdown, "--markdown") if args.markdown else None
        record = plan.file(args.write_baseline, "--write-baseline") if args.write_baseline else None
        gate_outputs_are_no_inputs(args, loaded, junit, md, record)
        with _report_folder(plan, args.report) as folder:
            with outputs.progress("gate", 4 * len(loaded)) as step:
                results = gate.compare_all(loaded, baseline, tolerances, step, noise=bool(args.write_baseline),
                                           report_dir=folder)
            for line in gate.warning_lines(results, baseline):
                print(line, file=sys.stderr)
            print(gate.format_table(results))
            if junit:
                gate.write_junit(junit, results)
            if md:
                gate.write_markdown(md, results, baseline)
            if record:
                gate.write_baseline(record, results)
            if folder is not None:
                _write_report(folder, [r.row for r in results if r.row is not None], "iblcheck gate")
    return EXIT_OK if all(r.passed for r in results) else EXIT_GATE_FAILED


def _cmd_report(args: argparse.Namespace) -> int:
    folder = Path(args.dir)
    if not (folder / sweep.RESULTS).is_file():
        raise UsageError(f"{folder / sweep.RESULTS}: not found (run `iblcheck sweep --out {folder}` first)")
    with outputs.Outputs() as plan, folder_lock(plan.folder(folder, "report"), "rebuild the report once it has"):
        for name in ("index.html", "summary.md"):
            plan.file(folder / name, "report")
        plan.folder(folder / "figures", "report")
        print(one_line(report.build(folder)))
    return EXIT_OK


def _cmd_paper(args: argparse.Namespace) -> int:
    _warn_broken_plugins()
    print(one_line(paper.run(Path(args.out), quick=args.quick, only=args.only, workers=args.workers,
                             scheduler=args.scheduler, command_line=COMMAND_LINE)))
    return EXIT_OK


#: options whose value is a list that may start with a minus sign (`--lod-biases -1,0,1`)
LIST_OPTIONS = ("--face-sizes", "--lod-biases", "--exponents", "--f0s", "--envs", "--lod-mappings", "--axis",
                "--set", "--min-psnr", "--min-ssim", "--max-flip", "--tolerance-db", "--tolerance-ssim",
                "--tolerance-flip", "--max-time-ratio", "--exposure")


def join_negative_values(argv: list[str]) -> list[str]:
    """argparse takes `-1,0,1` for an option; glue such a value to its option (`--lod-biases=-1,0,1`)."""
    out, i = [], 0
    while i < len(argv):
        a = argv[i]
        if a in LIST_OPTIONS and i + 1 < len(argv) and argv[i + 1].startswith("-") and len(argv[i + 1]) > 1 \
                and (argv[i + 1][1].isdigit() or argv[i + 1][1] == "."):
            out.append(f"{a}={argv[i + 1]}")
            i += 2
            continue
        out.append(a)
        i += 1
    return out


class PluginWarning(UserWarning):
    """A technique plugin that could not be registered (its one-line reason)."""


def _error(text: str) -> None:
    print(f"error: {one_line(text)}", file=sys.stderr)


class ClosedPipeGuard:
    """sys.stdout for one command: once its reader has gone (`iblcheck gate ... | head -1`), further output
    is dropped instead of raising BrokenPipeError, so that the command still writes its files and ends with
    its own exit code (a gate's pass or fail). The file descriptor is pointed at /dev/null then, so that the
    interpreter's last flush at exit does not fail either."""

    def __init__(self, stream) -> None:
        self.stream = stream
        self.reader_gone = False

    def _gone(self) -> None:
        self.reader_gone = True
        with contextlib.suppress(OSError, ValueError, AttributeError, io.UnsupportedOperation):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self.stream.fileno())
            os.close(devnull)

    def write(self, text: str) -> int:
        if not self.reader_gone:
            try:
                return self.stream.write(text)
            except BrokenPipeError:
                self._gone()
        return len(text)

    def flush(self) -> None:
        if not self.reader_gone:
            try:
                self.stream.flush()
            except BrokenPipeError:
                self._gone()

    def __getattr__(self, name: str):
        return getattr(self.stream, name)


def main(argv: list[str] | None = None) -> int:
    stdout = sys.stdout
    sys.stdout = ClosedPipeGuard(stdout)
    try:
        return _main(argv)
    finally:
        with contextlib.suppress(BrokenPipeError):
            sys.stdout.flush()
        sys.stdout = stdout


def _main(argv: list[str] | None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    parser = build_parser()
    try:
        args = parser.parse_args(join_negative_values(argv))
    except SystemExit as exc:  # argparse: --help (0) or a usage error (2, already printed)
        return int(exc.code or 0)
    warnings.simplefilter("default")
    warnings.showwarning = _WarnOnce()
    return run_command(args, debug)


class _WarnOnce:
    """Python warnings as `warning:` lines on stderr, each distinct line once per command: a sweep's rows
    each warn that the same scene lacks the same effect (each comparison's catch_warnings resets Python's own
    once-per-place registry), which said once is said."""

    def __init__(self) -> None:
        self.said: set[str] = set()

    def __call__(self, message, category, *args, **kwargs) -> None:
        line = f"warning: {one_line(message)}"
        if line not in self.said:
            self.said.add(line)
            print(line, file=sys.stderr)


def _interrupted_note(args: argparse.Namespace) -> str:
    """What an interruption leaves behind, for the command that was interrupted."""
    if args.func in (_cmd_sweep, _cmd_paper):
        return (f"the rows finished so far are kept in {getattr(args, 'out', 'the output folder')}/results.jsonl; "
                "rerun the same command to resume")
    if args.func is _cmd_gate:
        return "no verdict; every file is written whole or not at all; rerun the gate"
    return "every file is written whole or not at all; rerun the same command"


def run_command(args: argparse.Namespace, debug: bool = False) -> int:
    """Run a parsed command, mapping every way it can end to its exit code (see the module docstring)."""
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        _error(str(exc))
        return EXIT_BAD_INPUT
    except MissingCapability as exc:
        _error(f"{exc}" + (f"; {exc.hint}" if exc.hint else ""))
        return EXIT_MISSING
    except MemoryError:
        _error("out of memory; use smaller images (camera.width, camera.height), maps or meshes")
        return EXIT_MISSING
    except KeyboardInterrupt:
        _error(f"interrupted; {_interrupted_note(args)}")
        return EXIT_INTERRUPTED
    except OSError as exc:
        if exc.filename is None:
            return _internal(exc, debug)
        _error(f"{exc.filename}: {exc.strerror or exc}")
        return EXIT_BAD_INPUT
    except Exception as exc:  # a bug: its own exit code, never 1 (a failed gate)
        return _internal(exc, debug)


#: this command line's entry points, handed to the paper suite (E6 runs hostile commands through them)
COMMAND_LINE = CommandLine(main=main, run_command=run_command)


def _internal(exc: BaseException, debug: bool) -> int:
    if debug:
        traceback.print_exception(exc, file=sys.stderr)
    _error(f"internal error ({type(exc).__name__}: {exc})" + ("" if debug else "; rerun with --debug for the "
                                                               "traceback and report it"))
    return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
