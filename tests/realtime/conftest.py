"""Fixtures shared by the real-time renderer's GL tests."""

from __future__ import annotations

import pytest

from realtime.engine.context import get_context
from realtime.engine.gpu import EnvironmentFilter
from scenes.environment import environments


@pytest.fixture(scope="module")
def uffizi_64():
    """The Uffizi probe on a 64^2 cube with its box chain: (the cube texture, its level 0 faces (6, 64, 64, 3))."""
    f = EnvironmentFilter(get_context(), environments.builtin("uffizi"), 64)
    f.fill_base(0.0)
    f.build_chain()
    yield f.cube, f.read_level(0)
    f.release()
