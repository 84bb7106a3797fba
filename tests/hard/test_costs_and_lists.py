"""Two smaller promises: the quadrature's cost scales with what a map needs (a 3 x 100000 map once took
over 120 s and 22 GB at 48 x 48), and the README lists every builtin scene the package ships."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import scenes
from groundtruth.exact import quadrature
from scenes.environment import envmap

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("shape", [(3, 20000), (20000, 3), (64, 128)])
def test_the_cell_grid_looks_up_about_two_samples_per_texel_along_each_axis(shape, monkeypatch):
    """Lookups the grid makes: at most (2 per texel + 1 per cell) along u times the same along v, over the
    cells: the product of the two axes' needs, not the square of the larger one's."""
    counted = []
    lookup = envmap.lookup

    def counting(env, d, *args, **kwargs):
        counted.append(int(np.prod(np.shape(d)[:-1])))
        return lookup(env, d, *args, **kwargs)

    monkeypatch.setattr(envmap, "lookup", counting)
    env = np.ones(shape + (3,), np.float32)
    grid = quadrature.CellGrid(env, 128)
    h, w = shape
    bound = (2 * w + grid.w) * (2 * h + grid.h)
    assert 0 < sum(counted) <= bound
    np.testing.assert_allclose(grid.values, 1.0)  # a constant map stays constant


def test_control_the_old_square_rule_would_have_needed_far_more():
    # what one supersampling factor for both axes (the larger one's) would cost for a 3 x 20000 map
    h, w, cells_w = 3, 20000, 128
    ss = -(-2 * w // cells_w)
    assert (cells_w * ss) * (cells_w // 2 * ss) > 100 * (2 * w + cells_w) * (2 * h + cells_w // 2)


def test_the_readme_lists_every_builtin_scene():
    readme = (ROOT / "README.md").read_text()
    listed = set(re.findall(r"`([a-z]+(?:-[a-z]+)*)`\s+\(", readme.split("Builtin scenes:", 1)[1].split("\n\n", 1)[0]))
    assert listed == set(scenes.builtin_names())
