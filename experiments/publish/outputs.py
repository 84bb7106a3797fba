"""Where the CLI writes: checked before the work, written atomically, nowhere else.

- `Outputs` checks every output path a command will write before anything renders: a file where a
  folder is needed or the reverse, a device or pipe, a parent that cannot be created, a read-only
  or special file system (`/proc`) are `UsageError`s (exit 2) naming the option and the path. A
  missing folder is created then (and removed again if the command fails before using it).
- A file path that ends with a separator (`out.exr/`) names a folder and is refused (`file_path`),
  checked on the text as typed: `pathlib` would drop the slash.
- `write_text` / `write_bytes` write through a temporary file beside the target and a rename, so
  a failure (Ctrl-C included) leaves the old file or none, never half a file or a temporary one.
- `slug(name)` is the file-name form of a scene name for default output names: `name = "../../x"`
  or an absolute name cannot leave the folder it is written in.
- `progress(label, total)`: a progress bar for long work on stderr, and nothing at all when stderr is
  not a terminal (CI logs, pipes, tests), so stdout stays the command's result alone.
"""

from __future__ import annotations

import contextlib
import os
import re
import stat
import sys
import tempfile
import unicodedata
from collections.abc import Callable, Iterator
from pathlib import Path

from rich import progress as rp
from rich.console import Console

from experiments.publish.text import one_line
from scenes import InputError
from scenes.storage.files import write_bytes as _write_bytes

__all__ = ["Outputs", "UsageError", "file_path", "progress", "slug", "write_bytes", "write_text"]


class UsageError(InputError):
    """Bad command-line usage, such as an output path that cannot be written (exit 2). Defined here, below
    the CLI, because the output checks raise it; experiments/cli/inputs.py re-exports it."""


def slug(name: str, limit: int = 64) -> str:
    """A safe file-name stem for `name`: ASCII letters, digits, '.', '_' and '-' only, no leading
    dot, no '..', at most `limit` characters; "scene" when nothing is left."""
    text = unicodedata.normalize("NFKD", str(name)).encode("ascii", "ignore").decode()
    text = re.sub(r"[^A-Za-z0-9._-]+", "-", text)
    text = re.sub(r"\.{2,}", ".", text).strip(".-_")
    return text[:limit].rstrip(".-_") or "scene"


def file_path(text: str | Path, flag: str) -> Path:
    """`text`, an output file as the user typed it, as a Path; a UsageError (exit 2) when it ends with a
    path separator. `Path("out.exr/")` silently drops the slash, so the check must see the text itself:
    `out.exr/` and `newout/` both name a folder and are refused alike, naming the path."""
    seps = tuple(s for s in (os.sep, os.altsep) if s)
    if isinstance(text, str) and text.endswith(seps):
        raise UsageError(f"{flag} {one_line(text)}: ends with {text[-1]!r}, so it names a folder; give a file name")
    return Path(text)


def write_bytes(path: Path, data: bytes) -> None:
    """Write `data` to `path` atomically (scenes.storage.files.atomic_output)."""
    _write_bytes(path, data)


def write_text(path: Path, text: str) -> None:
    write_bytes(path, text.encode("utf-8"))


def rich_progress(*columns, **kwargs):
    """A rich Progress for long work (sweeps, the paper suite, PRT precomputation): on stderr, and off
    (`disable`) when stderr is not a terminal, so CI logs, pipes and a command's stdout never see it."""
    try:
        interactive = sys.stderr.isatty()
    except (AttributeError, ValueError):
        interactive = False
    return rp.Progress(*columns, console=Console(file=sys.stderr), disable=not interactive, **kwargs)


@contextlib.contextmanager
def progress(label: str, total: int, stream=None) -> Iterator[Callable[[str], None]]:
    """A progress bar of `total` steps on `stream` (default: sys.stderr at the time of the call).

    Yields `step(text)`: it counts the step begun before (if any) as done and shows `text` (user text:
    made visible and cut to one line, never read as rich markup) as the one now running; leaving the
    block counts the last. When `stream` is not a terminal, `step` does nothing and nothing is
    written, so CI logs and pipes never see the bar. The bar is transient: it is gone when the block
    ends, leaving the terminal to the command's own output.
    """
    stream = sys.stderr if stream is None else stream
    try:
        interactive = stream.isatty()
    except (AttributeError, ValueError):  # a closed or file-like stream
        interactive = False
    if not interactive:
        yield lambda text: None
        return
    columns = [rp.TextColumn(f"[bold]{label}"), rp.BarColumn(), rp.MofNCompleteColumn(), rp.TimeElapsedColumn(),
               rp.TextColumn("{task.description}", markup=False)]
    # stdout is never redirected: what a command prints there stays its result, even mid-bar
    with rp.Progress(*columns, console=Console(file=stream), transient=True, refresh_per_second=4,
                     redirect_stdout=False) as bar:
        task = bar.add_task("", total=total)
        begun = False

        def step(text: str) -> None:
            nonlocal begun
            if begun:
                bar.advance(task)
            begun = True
            bar.update(task, description=one_line(text, 120))

        yield step
        if begun:
            bar.advance(task)


def _why(exc: Exception) -> str:
    return (exc.strerror or str(exc)) if isinstance(exc, OSError) else "the name holds a NUL character"


class Outputs:
    """The output paths of one command, checked up front (see the module docstring).

    Use as a context manager: folders it created are removed again (when still empty) if the
    command fails."""

    def __init__(self) -> None:
        self.created: list[Path] = []

    def __enter__(self) -> Outputs:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            for folder in reversed(self.created):
                with contextlib.suppress(OSError):
                    folder.rmdir()

    def folder(self, path: str | Path, flag: str) -> Path:
        """A folder the command writes into: created if missing, and probed for writing."""
        path = Path(path)
        where = f"{flag} {path}"
        try:
            st = os.stat(path)
        except FileNotFoundError:
            st = None
        except (OSError, ValueError) as exc:
            raise UsageError(f"{where}: cannot be used as a folder ({_why(exc)})") from None
        if st is not None and not stat.S_ISDIR(st.st_mode):
            raise UsageError(f"{where}: is a file, not a folder")
        if st is None:
            self._make(path, where)
        self._probe(path, where)
        return path

    def file(self, path: str | Path, flag: str) -> Path:
        """A file the command writes: not a folder or a device; its folder exists (or is created)
        and can be written. A path typed with a trailing separator is refused (`file_path`)."""
        path = file_path(path, flag)
        where = f"{flag} {path}"
        if path.name in ("", ".", ".."):
            raise UsageError(f"{where}: names a folder; give a file name")
        try:
            st = os.stat(path)
        except FileNotFoundError:
            st = None
        except (OSError, ValueError) as exc:
            raise UsageError(f"{where}: cannot be written ({_why(exc)})") from None
        if st is not None and stat.S_ISDIR(st.st_mode):
            raise UsageError(f"{where}: is a folder; give a file name")
        if st is not None and not stat.S_ISREG(st.st_mode):
            raise UsageError(f"{where}: is not a regular file (a device, pipe or socket)")
        parent = path.parent
        if not parent.exists():
            self._make(parent, where)
        elif not parent.is_dir():
            raise UsageError(f"{where}: {parent} is a file, not a folder")
        self._probe(parent, where)
        return path

    def _make(self, path: Path, where: str) -> None:
        missing = []
        p = path
        while not p.exists() and p != p.parent:
            missing.append(p)
            p = p.parent
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UsageError(f"{where}: the folder {exc.filename or path} cannot be created ({_why(exc)})") from None
        self.created += reversed(missing)

    @staticmethod
    def _probe(folder: Path, where: str) -> None:
        """Create and remove a file in `folder`: the only test that a read-only or special file
        system (/proc, a full disk of inodes) passes or fails as the real write would."""
        try:
            fd, tmp = tempfile.mkstemp(prefix=".iblcheck-probe-", dir=folder)
        except OSError as exc:
            raise UsageError(f"{where}: cannot write in {folder} ({_why(exc)})") from None
        os.close(fd)
        os.unlink(tmp)


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether two paths name the same existing file."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False
