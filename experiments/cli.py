"""The `iblcheck` command line (design.md section 6).

Exit codes: 0 success, 1 a gate failed, 2 bad input or usage (one `error: ...` line on stderr,
no traceback), 3 the machine lacks something (a line saying what to install).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Callable

from scenes import InputError, MissingCapability

EXIT_OK, EXIT_GATE_FAILED, EXIT_BAD_INPUT, EXIT_MISSING = 0, 1, 2, 3


class UsageError(InputError):
    """Bad command-line usage (exit 2)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # argparse's own errors: one line, exit 2
        print(f"error: {message}", file=sys.stderr)
        raise SystemExit(EXIT_BAD_INPUT)


def parse_sets(items: list[str] | None) -> dict[str, str]:
    """`--set K=V` pairs -> {K: V}; values are parsed as TOML literals by Scene.with_overrides."""
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise UsageError(f"--set {item!r}: expected KEY=VALUE, e.g. --set realtime.lod_bias=2")
        out[key.strip()] = value.strip()
    return out


def load_scene(spec: str, sets: list[str] | None = None):
    import scenes

    scene = scenes.load(spec)
    overrides = parse_sets(sets)
    return scene.with_overrides(overrides) if overrides else scene


def _not_yet(name: str) -> Callable[[argparse.Namespace], int]:
    def run(args: argparse.Namespace) -> int:
        raise UsageError(f"'iblcheck {name}' is not implemented yet")

    return run


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="iblcheck", description="Validate real-time environment lighting against path-traced references.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    r = sub.add_parser("render", help="render one scene with one renderer, write EXR + PNG")
    r.add_argument("scene", help="scene file or builtin:NAME")
    r.add_argument("--renderer", choices=["realtime", "reference", "quadrature"], default="realtime")
    r.add_argument("--set", action="append", metavar="K=V", help="override a scene key (repeatable)")
    r.add_argument("-o", "--out", default=None, help="output .exr path (a .png is written beside it)")
    r.set_defaults(func=_cmd_render)

    c = sub.add_parser("compare", help="real-time vs reference metrics for one scene")
    c.add_argument("scene")
    c.add_argument("--set", action="append", metavar="K=V")
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=_not_yet("compare"))

    s = sub.add_parser("sweep", help="metrics and timings across face sizes and LOD biases")
    s.add_argument("scenes", nargs="+")
    s.add_argument("--face-sizes", default="8,16,32,64")
    s.add_argument("--lod-biases", default="-1,0,1,2")
    s.add_argument("--out", default="reports/sweep")
    s.set_defaults(func=_not_yet("sweep"))

    g = sub.add_parser("gate", help="CI image-quality gate (exit 1 on failure)")
    g.add_argument("scenes", nargs="+")
    g.add_argument("--min-psnr", type=float)
    g.add_argument("--min-ssim", type=float)
    g.add_argument("--max-flip", type=float)
    g.add_argument("--junit")
    g.set_defaults(func=_not_yet("gate"))

    rep = sub.add_parser("report", help="regenerate DIR/index.html from DIR/results.jsonl")
    rep.add_argument("dir")
    rep.set_defaults(func=_not_yet("report"))

    pa = sub.add_parser("paper", help="run the paper-style experiment suite (the main job)")
    pa.add_argument("--out", default="reports/paper")
    pa.add_argument("--quick", action="store_true")
    pa.set_defaults(func=_not_yet("paper"))
    return p


def _cmd_render(args: argparse.Namespace) -> int:
    from . import render_cmd

    return render_cmd.run(args)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    warnings.simplefilter("default")
    warnings.showwarning = lambda msg, cat, *a, **k: print(f"warning: {msg}", file=sys.stderr)
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except MissingCapability as exc:
        print(f"error: {exc}" + (f"; {exc.hint}" if exc.hint else ""), file=sys.stderr)
        return EXIT_MISSING
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
