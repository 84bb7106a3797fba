"""The `iblcheck` command's entry point (pyproject's console script, `python -m experiments.cli`).

The command line's own imports (Mitsuba's and Dask's wrappers, every technique's declaration) take a second or
more before `experiments.cli.main.run_command` maps a Ctrl-C to one `error:` line and exit 130. A Ctrl-C during
them ends the same way here, where it had printed Python's traceback of whichever import it landed in; nothing
has been written by then. So does one outside `run_command` later (while the arguments are parsed).
"""

from __future__ import annotations

import sys

EXIT_INTERRUPTED = 130  # experiments.cli.main.EXIT_INTERRUPTED, which this module must not import at its top


def main(argv: list[str] | None = None) -> int:
    try:
        # the one import that cannot sit at the top: the interrupt this function turns into exit 130 can land in it
        from experiments.cli import main as command_line
    except KeyboardInterrupt:
        sys.stderr.write("error: interrupted while starting; nothing was written\n")
        return EXIT_INTERRUPTED
    try:
        return command_line.main(argv)
    except KeyboardInterrupt:
        # a command's own interrupt is run_command's, with what it kept; this one came outside it (while the
        # arguments were parsed, or a second Ctrl-C while the first was reported)
        sys.stderr.write("error: interrupted\n")
        return EXIT_INTERRUPTED
