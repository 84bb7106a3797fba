"""The quadrature's cell grid supersamples each axis as its map needs: the cell averages of maps much
wider than tall (or taller than wide) equal a brute-force average of the same bilinear environment."""

from __future__ import annotations

import numpy as np
import pytest

from groundtruth.exact.quadrature import CellGrid
from scenes.environment import envmap
from scenes.environment.directions import uv_to_direction


def brute_force_cell(env: np.ndarray, grid: CellGrid, row: int, col: int, n: int = 400) -> np.ndarray:
    """The solid-angle-weighted mean of envmap.lookup over one cell, by an n x n midpoint rule."""
    v = (row + (np.arange(n) + 0.5) / n) / grid.h
    u = (col + (np.arange(n) + 0.5) / n) / grid.w
    vals = envmap.lookup(env, uv_to_direction(u[None, :], v[:, None])).astype(np.float64)
    w = np.sin(np.pi * v)[:, None, None]
    return (vals * w).sum(axis=(0, 1)) / (w.sum() * n)


@pytest.mark.parametrize("shape", [(3, 3000), (1500, 4), (64, 128)])
def test_cell_averages_of_narrow_maps_match_a_brute_force_mean(shape):
    env = np.random.default_rng(sum(shape)).uniform(0.1, 1.0, shape + (3,)).astype(np.float32)
    grid = CellGrid(env, 32)
    for row, col in [(0, 0), (3, 17), (8, 31), (15, 5)]:
        # both are midpoint rules (2 and 4 lookups per texel)
        np.testing.assert_allclose(grid.values[row, col], brute_force_cell(env, grid, row, col), rtol=5e-3)


def test_control_one_lookup_per_cell_misses_the_detail():
    # the control: a wide map's cell is not its centre's value (the supersampling is what matters)
    env = np.random.default_rng(3).uniform(0.1, 1.0, (3, 3000, 3)).astype(np.float32)
    grid = CellGrid(env, 32)
    centre = envmap.lookup(env, grid.dirs[3, 17])
    assert np.abs(centre - brute_force_cell(env, grid, 3, 17)).max() > 0.05
