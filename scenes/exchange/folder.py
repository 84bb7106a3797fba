"""An output folder written whole or not at all.

`atomic_folder(target, is_ours)` yields a new temporary folder beside `target`; when the block succeeds it
takes `target`'s place (an earlier folder that `is_ours` recognises is replaced, then removed), and on
any failure (Ctrl-C included) the temporary folder is removed and `target` is left as it was. A target
that exists and is not empty is refused unless `is_ours(target)`, so a typo never replaces someone's folder.
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


def check_target(target: Path, is_ours: Callable[[Path], bool], what: str) -> None:
    """Refuse a target that is a file, or a folder that holds something other than an earlier `what`."""
    if target.is_symlink() or (target.exists() and not target.is_dir()):
        raise InputError(f"{target}: exists and is not a folder")
    if target.is_dir() and any(target.iterdir()) and not is_ours(target):
        raise InputError(f"{target}: the folder exists, is not empty and holds no earlier {what}; choose a new or "
                         "empty folder")


@contextlib.contextmanager
def atomic_folder(target: str | Path, is_ours: Callable[[Path], bool], what: str) -> Iterator[Path]:
    target = Path(target)
    check_target(target, is_ours, what)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name[:60]}.", suffix=".tmp", dir=target.parent))
    old = None
    try:
        os.chmod(tmp, output_mode() | 0o111)
        yield tmp
        check_target(target, is_ours, what)  # again: it may have changed while the files were written
        if target.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{target.name[:60]}.", suffix=".old", dir=target.parent))
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
