"""Cube-edge neighbours and the seam measure (realtime/engine/cube_seams.py), pure numpy."""

from __future__ import annotations

import numpy as np
import pytest

from realtime.engine.cube_seams import edge_pairs, seam_residual
from scenes.environment import cubemap


@pytest.mark.parametrize("size", [2, 4, 16])
def test_neighbours_across_an_edge_are_adjacent_border_texels_of_another_face(size):
    e, a, i = edge_pairs(size)
    assert len(e) == 6 * 4 * size
    d = cubemap.texel_directions(size)
    assert np.all(a[:, 0] != e[:, 0]) and np.all(i[:, 0] == e[:, 0])
    on_border = (a[:, 1] == 0) | (a[:, 1] == size - 1) | (a[:, 2] == 0) | (a[:, 2] == size - 1)
    assert np.all(on_border)
    across = np.arccos(np.clip(np.sum(d[tuple(e.T)] * d[tuple(a.T)], axis=-1), -1, 1))
    inward = np.arccos(np.clip(np.sum(d[tuple(e.T)] * d[tuple(i.T)], axis=-1), -1, 1))
    assert across.max() <= 1.5 * inward.max()  # the nearest texel over the edge, not a far one


def test_a_smooth_function_sampled_at_texel_centres_has_no_seam():
    mu = np.array([0.3, 0.8, -0.5]) / np.linalg.norm([0.3, 0.8, -0.5])
    for size in (4, 16, 64):
        faces = np.exp(2.0 * (cubemap.texel_directions(size) @ mu))[..., None]
        assert abs(seam_residual(faces)["ratio"] - 1.0) < 0.03
