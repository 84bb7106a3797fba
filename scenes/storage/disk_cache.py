"""The on-disk cache folder both renderers share: where it is, atomic entries, and a lock per key.

Location: `$IBLCHECK_CACHE`, default `~/.cache/iblcheck`. The reference cache
(groundtruth/pathtracer/reference_cache.py) keeps its entries at the top of the folder, the PRT
transfer cache (realtime/techniques/prt/prt_transfer.py) below `prt/`. A folder that cannot be written
is the caller's warning (CacheWarning), never a lost result.
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np


def digest_arrays(h, *arrays: np.ndarray) -> None:
    """Feed each array's dtype, shape and bytes (C order) to the hash `h`: a cache key's digest of content,
    so arrays of equal bytes but another dtype or shape key differently."""
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())


class CacheWarning(UserWarning):
    """The cache could not be used as intended (corrupt entry, unwritable folder); the render goes on."""


def cache_dir() -> Path:
    return Path(os.environ.get("IBLCHECK_CACHE") or Path.home() / ".cache" / "iblcheck")


def write_npz(folder: Path, key: str, **arrays: np.ndarray) -> None:
    """`folder/key.npz` written atomically (a temporary file in the same folder, fsync, rename): readers
    see the old entry or the whole new one, never part of it. Raises OSError (the temporary file is
    removed). Shared by the reference cache and the PRT cache."""
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    folder.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{key[:16]}-", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(buf.getvalue())
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, folder / f"{key}.npz")
    except OSError:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def locked(key: str) -> Iterator[None]:
    """Hold an exclusive advisory lock for `key` while rendering it (no-op where locks are unavailable)."""
    try:
        import fcntl  # deferred: POSIX only
    except ImportError:  # pragma: no cover (Windows)
        yield
        return
    folder = cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd = os.open(folder / f"{key}.lock", os.O_RDWR | os.O_CREAT, 0o644)
    except OSError:
        yield  # unwritable cache: nothing to protect
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)
