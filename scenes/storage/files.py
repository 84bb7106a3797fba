"""Input files and atomic output files, with clear reasons when a path cannot be used.

- `input_problem(path)`: why a path cannot be read as an input file (a folder, a device, a named
  pipe, a symbolic link loop, a broken link, no permission, a NUL in the name, ...), or None.
  Readers say that instead of "file not found", and never block on a pipe or follow a loop.
- `short_repr(value)`: a bounded repr for error messages (a million-element list stays one line).
- `atomic_output(path)`: a temporary file beside `path`, renamed onto it when the block succeeds
  and removed on any failure (Ctrl-C included), so a failed write leaves neither a half-written
  file nor a temporary one.
"""

from __future__ import annotations

import contextlib
import errno
import os
import reprlib
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

_REPR = reprlib.Repr()
_REPR.maxstring = 80
_REPR.maxother = 80
_REPR.maxlist = _REPR.maxtuple = _REPR.maxdict = 8
_REPR.maxlevel = 3

#: the process's umask, so that atomic outputs get the usual 0666 & ~umask mode (mkstemp makes 0600)
_UMASK = os.umask(0)
os.umask(_UMASK)


def short_repr(value: object) -> str:
    """repr(value), cut to a readable length and depth."""
    try:
        return _REPR.repr(value)
    except (RecursionError, ValueError):  # pragma: no cover (reprlib bounds the depth itself)
        return f"<{type(value).__name__}>"


def _stat_problem(path: Path, exc: OSError) -> str:
    if exc.errno == errno.ELOOP:
        return "is a symbolic link loop"
    if exc.errno == errno.ENOENT:
        if os.path.islink(path):
            return f"is a broken symbolic link (to {os.readlink(path)})"
        return "not found"
    if exc.errno == errno.ENOTDIR:
        return "not found (a part of the path is a file, not a folder)"
    if exc.errno == errno.ENAMETOOLONG:
        return "the name is too long"
    if exc.errno == errno.EACCES:
        return "permission denied"
    return f"cannot be read ({exc.strerror or exc})"


def input_problem(path: str | Path) -> str | None:
    """Why `path` cannot be read as an input file, or None when it is a readable regular file."""
    try:
        st = os.stat(path)
    except ValueError:  # an embedded NUL character
        return "the name holds a NUL character"
    except OSError as exc:
        return _stat_problem(Path(path), exc)
    mode = st.st_mode
    if stat.S_ISDIR(mode):
        return "is a folder, not a file"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "is a device, not a file"
    if stat.S_ISFIFO(mode):
        return "is a named pipe (FIFO), not a file"
    if stat.S_ISSOCK(mode):
        return "is a socket, not a file"
    if not stat.S_ISREG(mode):
        return "is not a regular file"
    try:
        with open(path, "rb"):
            pass
    except OSError as exc:
        return _stat_problem(Path(path), exc)
    return None


def read_input(path: Path, kind: str, limit: int, error: type[Exception]) -> bytes:
    """The bytes of an input file (`kind`: "scene file", "mesh file", ...): a readable regular file of at
    most `limit` bytes, else `error` naming the path and what is wrong."""
    problem = input_problem(path)
    if problem:
        raise error(f"{path}: {kind} {problem}")
    size = path.stat().st_size
    if size > limit:
        raise error(f"{path}: {kind} of {size} bytes, more than the limit of {limit}")
    return path.read_bytes()


def output_mode() -> int:
    return 0o666 & ~_UMASK


@contextlib.contextmanager
def atomic_output(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path in `path`'s folder; on success it replaces `path`, on failure it is removed."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name[:60]}.", suffix=".tmp", dir=path.parent)
    try:
        try:
            os.fchmod(fd, output_mode())
        finally:
            os.close(fd)
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_bytes(path: str | Path, data: bytes) -> None:
    """Write `data` to `path` atomically (see atomic_output)."""
    with atomic_output(path) as tmp:
        tmp.write_bytes(data)
