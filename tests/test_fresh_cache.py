"""The test run's disk cache is new and empty at the start of each run (tests/conftest.py), so no test can
pass on a reference or a PRT transfer that another version of the code wrote."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from scenes.storage.disk_cache import cache_dir


def test_the_runs_cache_is_a_new_temporary_folder_not_the_users_cache() -> None:
    """The library's cache folder during tests is a `iblcheck-test-cache-*` folder under the system's temporary
    directory (made by this run), never `~/.cache/iblcheck` where earlier runs and users leave entries."""
    folder = cache_dir()
    assert folder.parent == Path(tempfile.gettempdir())
    assert folder.name.startswith("iblcheck-test-cache-")
    assert folder != Path.home() / ".cache" / "iblcheck"
    assert os.environ["IBLCHECK_CACHE"] == str(folder)
