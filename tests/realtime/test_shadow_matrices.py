"""The shadow maps' light matrices (realtime/shadow_maps.light_matrices), numpy only: each is an
orthographic view along -l of the objects' bounding sphere (centre c, radius R), depth over [R, 3R]."""

from __future__ import annotations

import numpy as np
import pytest

from realtime.techniques.shadow_maps.shadow_maps import light_matrices
from scenes.environment import light_array


@pytest.mark.parametrize("count", [4, 42, 642])
def test_light_matrices_frame_the_bounding_sphere(count):
    d = light_array.geodesic_directions(count)
    c, r = np.array([0.1, 0.2, -0.3]), 1.7
    m = light_matrices(d, c, r)
    # the centre sits in the middle of every map and of its depth range
    np.testing.assert_allclose(m @ np.r_[c, 1.0], np.broadcast_to([0, 0, 0, 1], (count, 4)), atol=1e-12)
    # the sphere's point nearest the light is on the near plane (NDC z = -1), the farthest on the far one
    for sign, z in ((1.0, -1.0), (-1.0, 1.0)):
        p = np.c_[c + sign * r * d, np.ones(count)]
        np.testing.assert_allclose(np.einsum("nij,nj->ni", m, p)[:, 2], z, atol=1e-12)
    # the image plane is perpendicular to l and the sphere's silhouette touches the map's edges
    rows = m[:, :2, :3] * r
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", rows, rows), np.broadcast_to(np.eye(2), (count, 2, 2)),
                               atol=1e-12)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", rows, d), 0.0, atol=1e-12)
