"""An output folder written whole or not at all.

`atomic_folder(target, is_ours)` yields a new temporary folder beside `target`; when the block succeeds it
takes `target`'s place (an earlier folder that `is_ours` recognises is replaced, then removed), and on
any failure (Ctrl-C included) the temporary folder is removed and `target` is left as it was. A target
that exists and is not empty is refused unless `is_ours(target)` and it holds only files named in
`own_names` (what the writer itself writes), so neither a typo nor a re-run loses anyone's file: an engine's
image saved into an earlier export is named in the refusal, not deleted.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from scenes.storage.errors import InputError
from scenes.storage.files import output_mode


def check_target(target: Path, is_ours: Callable[[Path], bool], what: str, own_names: frozenset[str]) -> None:
    """Refuse a target that is a file, a folder that holds something other than an earlier `what`, or an
    earlier `what` beside which something else was saved (it would be lost with the folder)."""
    if target.is_symlink() or (target.exists() and not target.is_dir()):
        raise InputError(f"{target}: exists and is not a folder")
    if not target.is_dir() or not any(target.iterdir()):
        return
    if not is_ours(target):
        raise InputError(f"{target}: the folder exists, is not empty and holds no earlier {what}; choose a new or "
                         "empty folder")
    foreign = sorted(p.name for p in target.iterdir() if p.name not in own_names)
    if foreign:
        more = f" (and {len(foreign) - 1} more)" if len(foreign) > 1 else ""
        raise InputError(f"{target}: holds {foreign[0]!r}{more}, which no {what} writes; replacing the earlier "
                         f"{what} would delete it: move it out or choose a new folder")


def _make_temporary(target: Path, suffix: str) -> Path:
    """A new folder beside `target`; a parent that cannot hold one is an InputError naming `target`."""
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        return Path(tempfile.mkdtemp(prefix=f".{target.name[:60]}.", suffix=suffix, dir=target.parent))
    except OSError as exc:
        raise InputError(f"{target}: cannot write a folder in {target.parent} ({exc.strerror or exc})") from None


@contextlib.contextmanager
def atomic_folder(target: str | Path, is_ours: Callable[[Path], bool], what: str,
                  own_names: frozenset[str]) -> Iterator[Path]:
    target = Path(target)
    check_target(target, is_ours, what, own_names)
    tmp = _make_temporary(target, ".tmp")
    old = None
    try:
        os.chmod(tmp, output_mode() | 0o111)
        yield tmp
        check_target(target, is_ours, what, own_names)  # again: it may have changed while the files were written
        if target.exists():
            old = _make_temporary(target, ".old")
            os.replace(target, old / "x")
        os.replace(tmp, target)
    except BaseException:
        if old is not None and not target.exists():
            os.replace(old / "x", target)
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
