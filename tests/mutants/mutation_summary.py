"""Per-module summary of a finished `mutmut run` (called by `make mutation`, from the mutmut project folder).

    python tests/mutants/mutation_summary.py [--diffs]

Prints, per mutated module, how many mutants were killed, survived, are known to be equivalent, had no covering
test, timed out or were otherwise unresolved, then every survivor (with its one-line diff when `--diffs` is
given). A survivor is "equivalent" when tests/mutants/equivalent_mutants.toml lists its function and its diff
with the reason it cannot change any output; every other survivor is a gap in the tests.
"""

from __future__ import annotations

import argparse
import collections
import re
import subprocess
import sys
import tomllib
from pathlib import Path

MUTMUT = str(Path(sys.executable).with_name("mutmut"))
LINE = re.compile(r"^\s*(?P<name>[\w.ǁ]+)__mutmut_(?P<n>\d+): (?P<status>.+)$")
EQUIVALENT_FILE = Path(__file__).with_name("equivalent_mutants.toml")
STATUSES = ["killed", "survived", "equivalent", "no tests", "timeout", "suspicious", "skipped", "not checked"]


def results() -> list[tuple[str, str, str]]:
    """(module, mutant name, status) of every mutant."""
    out = subprocess.run([MUTMUT, "results", "--all", "true"], capture_output=True, text=True, check=True).stdout
    rows = []
    for line in out.splitlines():
        m = LINE.match(line)
        if m:
            module = m["name"].rsplit(".", 1)[0]
            rows.append((module, f"{m['name']}__mutmut_{m['n']}", m["status"].strip()))
    return rows


def diff_of(name: str) -> str:
    """The mutant's changed lines, `- old | + new`, stripped of indentation."""
    out = subprocess.run([MUTMUT, "show", name], capture_output=True, text=True).stdout
    changed = [line for line in out.splitlines() if line[:1] in "+-" and line[:3] not in ("+++", "---")]
    return " | ".join(line[0] + " " + line[1:].strip() for line in changed)


def equivalents(path: Path = EQUIVALENT_FILE) -> dict[tuple[str, str], str]:
    """{(function, diff): reason} of the mutants known to change no output."""
    if not path.is_file():
        return {}
    entries = tomllib.loads(path.read_text()).get("equivalent", [])
    return {(e["function"], e["diff"]): e["why"] for e in entries}


def function_of(name: str) -> str:
    """`scenes.environment.spheremap.x_density__mutmut_5` -> `scenes.environment.spheremap.x_density`."""
    return name.rsplit("__mutmut_", 1)[0]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--diffs", action="store_true", help="show each survivor's diff")
    args = parser.parse_args(argv)
    known = equivalents()
    counts: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    survivors: list[tuple[str, str]] = []
    for module, name, status in results():
        if status == "survived":
            diff = diff_of(name)
            if (function_of(name), diff) in known:
                status = "equivalent"
            else:
                survivors.append((name, diff))
        counts[module][status] += 1
    print(f"{'module':<48}" + "".join(f"{s:>12}" for s in STATUSES))
    for module in sorted(counts):
        if sum(counts[module][s] for s in STATUSES if s != "not checked"):
            print(f"{module:<48}" + "".join(f"{counts[module][s]:>12}" for s in STATUSES))
    print(f"\n{len(survivors)} survivors (not listed as equivalent in {EQUIVALENT_FILE.name})")
    for name, diff in survivors:
        print(f"  {name}" + (f"\n      {diff}" if args.diffs else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
