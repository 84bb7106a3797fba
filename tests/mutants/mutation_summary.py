"""Per-module summary of a finished `mutmut run` (called by `make mutation`, from the mutmut project folder).

    python tests/mutants/mutation_summary.py [--diffs]

Prints, per mutated module, how many mutants were killed, survived, had no covering test, timed out or
were otherwise unresolved, then every survivor (with its one-line diff when `--diffs` is given).
"""

from __future__ import annotations

import argparse
import collections
import re
import subprocess
import sys
from pathlib import Path

MUTMUT = str(Path(sys.executable).with_name("mutmut"))
LINE = re.compile(r"^\s*(?P<name>[\w.]+)__mutmut_(?P<n>\d+): (?P<status>.+)$")


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
    out = subprocess.run([MUTMUT, "show", name], capture_output=True, text=True).stdout
    changed = [line for line in out.splitlines() if line[:1] in "+-" and line[:3] not in ("+++", "---")]
    return " | ".join(line.strip() for line in changed)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--diffs", action="store_true", help="show each survivor's diff")
    args = parser.parse_args(argv)
    rows = results()
    counts: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    for module, _, status in rows:
        counts[module][status] += 1
    statuses = ["killed", "survived", "no tests", "timeout", "suspicious", "skipped", "not checked"]
    print(f"{'module':<28}" + "".join(f"{s:>12}" for s in statuses))
    for module in sorted(counts):
        print(f"{module:<28}" + "".join(f"{counts[module][s]:>12}" for s in statuses))
    survivors = [name for _, name, status in rows if status == "survived"]
    print(f"\n{len(survivors)} survivors")
    for name in survivors:
        print(f"  {name}" + (f"\n      {diff_of(name)}" if args.diffs else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
