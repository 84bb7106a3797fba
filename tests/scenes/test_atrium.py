"""The procedural atrium (scenes/geometry/atrium.py): its triangle count against a hand count, its bounds
against the design's dimensions, no degenerate triangle, normals agreeing with the winding, and every
closed part a closed outward-facing 2-manifold of the volume its shape has."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenes.geometry import atrium
from scenes.storage.errors import MeshError


def hand_count(b: int, d: int) -> int:
    # counted part by part, each from its construction (not from atrium.triangle_count):
    # a column: an 8d-gon side of 2d rings (2 triangles per quad) and two fans of 8d; 4b per storey, 2 storeys
    column = 2 * (8 * d) * (2 * d) + 2 * (8 * d)
    # an arch: a rectangle (4 sides) along 8d segments, two caps of 4 triangles; 4b per storey
    arch = 2 * 4 * (8 * d) + 2 * 4
    # a box: a section of 4 sides of d segments along d segments, two fans of 4d; 4 slabs, 4 parapets, 4 walls
    box = 2 * (4 * d) * d + 2 * (4 * d)
    ground = 2 * (2 * d * b) ** 2
    drape = 2 * (4 * d) ** 2  # 4b drapes
    return 8 * b * column + 8 * b * arch + 12 * box + ground + 4 * b * drape


def test_one_bay_atrium_has_1288_triangles():
    # 8 columns x 48 + 8 arches x 72 + 12 boxes x 16 + ground 8 + 4 drapes x 32
    assert 8 * 48 + 8 * 72 + 12 * 16 + 8 + 4 * 32 == 1288
    assert atrium.atrium(1, 1).n_triangles == 1288


@pytest.mark.parametrize("b, d", [(1, 1), (1, 3), (2, 1), (2, 3), (3, 2), (4, 7)])
def test_triangle_count_formula(b, d):
    assert atrium.triangle_count(b, d) == hand_count(b, d)
    assert atrium.atrium(b, d).n_triangles == hand_count(b, d)


def test_named_sizes_reach_the_stated_orders():
    counts = {name: atrium.triangle_count(*bd) for name, bd in atrium.SIZES.items()}
    assert 1e4 <= counts["10k"] < 2e4 and 1e5 <= counts["100k"] < 2e5
    assert 1e6 <= counts["1M"] < 1.2e6 and 2e6 <= counts["2M"] < 2.2e6


@pytest.mark.parametrize("b", [1, 2, 5])
def test_bounds(b):
    m = atrium.atrium(b, 1)
    # the outer walls' outer faces: half the courtyard (b bays of 4 m) + the 3 m aisle + the 0.2 m wall
    outer = b * 4.0 / 2 + 3.0 + 0.2
    np.testing.assert_allclose(m.positions.min(axis=0), [-outer, 0.0, -outer], atol=1e-5)
    np.testing.assert_allclose(m.positions.max(axis=0), [outer, 9.0, outer], atol=1e-5)


@pytest.mark.parametrize("b, d", [(1, 1), (2, 3), (4, 7)])
def test_no_degenerate_triangles_and_normals_follow_the_winding(b, d):
    m = atrium.atrium(b, d)
    p = m.positions.astype(np.float64)
    fn = m.face_normals()
    area = 0.5 * np.linalg.norm(fn, axis=1)
    assert area.min() > 1e-6
    assert np.isfinite(m.normals).all()
    np.testing.assert_allclose(np.linalg.norm(m.normals, axis=1), 1.0, atol=1e-5)
    # every corner's vertex normal on the front side of its face (a flipped part would be negative)
    dots = np.einsum("fk,fck->fc", fn / (2 * area[:, None]), m.normals[m.indices].astype(np.float64))
    assert dots.min() > 0.1
    assert len(np.unique(m.indices)) == len(p)  # no unused vertex


def test_deterministic():
    a, b = atrium.atrium(2, 2), atrium.atrium(2, 2)
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.indices, b.indices)


def is_closed_manifold(p: np.ndarray, idx: np.ndarray) -> bool:
    """Every directed edge (by welded position) once, and its reverse once."""
    _, weld = np.unique(np.round(p, 9), axis=0, return_inverse=True)
    w = weld.reshape(-1)[idx]
    edges = [tuple(e) for e in np.concatenate([w[:, [0, 1]], w[:, [1, 2]], w[:, [2, 0]]])]
    return len(set(edges)) == len(edges) and all((e[1], e[0]) in set(edges) for e in edges)


def signed_volume(p: np.ndarray, idx: np.ndarray) -> float:
    # divergence theorem: sum over faces of det(a, b, c) / 6, positive for outward-facing winding
    a, b, c = p[idx[:, 0]], p[idx[:, 1]], p[idx[:, 2]]
    return float(np.einsum("fk,fk->f", a, np.cross(b, c)).sum() / 6.0)


def test_closed_parts_are_closed_and_face_outward():
    parts = atrium.parts(1, 2)
    closed = [q for q in parts if q.closed]
    assert {q.name.split("_")[0] for q in closed} == {"column", "arch", "slab", "parapet", "wall"}
    for q in closed:
        assert is_closed_manifold(q.positions, q.indices), q.name
        assert signed_volume(q.positions, q.indices) > 0, q.name
    # volumes by shape: a ground-floor column is a regular 16-gon prism (r 0.3, h 4), a wall a 0.2-thick box
    col = next(q for q in parts if q.name == "column_0_0_0")
    k = 16
    prism = k / 2 * 0.3 ** 2 * math.sin(2 * math.pi / k) * 4.0
    assert signed_volume(col.positions, col.indices) == pytest.approx(prism)
    wall = next(q for q in parts if q.name == "wall_0")
    outer = 4.0 / 2 + 3.0
    assert signed_volume(wall.positions, wall.indices) == pytest.approx(2 * (outer + 0.2) * 0.2 * 9.0)
    # an arch: its rectangle (0.5 x 0.3) swept along a 16-segment semicircle of radius 2 (Pappus, chords)
    arch = next(q for q in parts if q.name == "arch_0_0_0")
    chord = 2 * 2.0 * math.sin(math.pi / 32)
    assert signed_volume(arch.positions, arch.indices) == pytest.approx(16 * chord * math.cos(math.pi / 32) * 0.5 * 0.3,
                                                                        rel=1e-9)


def test_controls_reversed_winding_and_open_column_are_caught():
    col = next(q for q in atrium.parts(1, 1) if q.name == "column_0_0_0")
    assert signed_volume(col.positions, col.indices[:, ::-1]) < 0
    k = 8  # the top cap is the last 8 triangles
    assert not is_closed_manifold(col.positions, col.indices[:-k])


def test_sheets_face_the_courtyard_and_the_sky():
    parts = atrium.parts(2, 1)
    ground = next(q for q in parts if q.name == "ground")
    a, b, c = (ground.positions[ground.indices[:, i]] for i in range(3))
    assert (np.cross(b - a, c - a)[:, 1] > 0).all()  # up
    drape = next(q for q in parts if q.name == "drape_0_0")  # side 0 is +z: faces -z, toward the courtyard
    a, b, c = (drape.positions[drape.indices[:, i]] for i in range(3))
    assert (np.cross(b - a, c - a)[:, 2] < 0).all()


@pytest.mark.parametrize("b, d", [(0, 1), (1, 0), (65, 1), (1.5, 1), (True, 1)])
def test_bad_sizes_are_refused(b, d):
    with pytest.raises(MeshError, match="atrium"):
        atrium.atrium(b, d)


def test_unknown_size_name():
    with pytest.raises(MeshError, match="'huge'"):
        atrium.atrium_of_size("huge")
