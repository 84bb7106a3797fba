"""Cube faces follow the OpenGL table (docs/contract.md section 2); solid angles are exact."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.environment import cubemap

S3 = 1 / np.sqrt(3)
# Hand-derived from the OpenGL specification's cube-map table, per face:
# centre (sc = tc = 0) and the corner texels' limit directions at (s, t) = (0, 0), (1, 0), (0, 1), (1, 1)
# (sc, tc = -1 or +1), before normalisation.
TABLE = {
    0: ((1, 0, 0), [(1, 1, 1), (1, 1, -1), (1, -1, 1), (1, -1, -1)]),  # +X (1, -tc, -sc)
    1: ((-1, 0, 0), [(-1, 1, -1), (-1, 1, 1), (-1, -1, -1), (-1, -1, 1)]),  # -X (-1, -tc, sc)
    2: ((0, 1, 0), [(-1, 1, -1), (1, 1, -1), (-1, 1, 1), (1, 1, 1)]),  # +Y (sc, 1, tc)
    3: ((0, -1, 0), [(-1, -1, 1), (1, -1, 1), (-1, -1, -1), (1, -1, -1)]),  # -Y (sc, -1, -tc)
    4: ((0, 0, 1), [(-1, 1, 1), (1, 1, 1), (-1, -1, 1), (1, -1, 1)]),  # +Z (sc, -tc, 1)
    5: ((0, 0, -1), [(1, 1, -1), (-1, 1, -1), (1, -1, -1), (-1, -1, -1)]),  # -Z (-sc, -tc, -1)
}


@pytest.mark.parametrize("face", range(6), ids=cubemap.FACE_NAMES)
def test_face_centre_and_corners(face):
    centre, corners = TABLE[face]
    # an odd size has a texel exactly at the centre
    d = cubemap.texel_directions(5)[face]
    np.testing.assert_allclose(d[2, 2], centre, atol=1e-12)
    # texel centres approach the corners as the face gets finer: corner texel of a 2048 face
    size = 2048
    dirs = cubemap.texel_directions(size)[face]
    got = [dirs[0, 0], dirs[0, -1], dirs[-1, 0], dirs[-1, -1]]  # (row t, col s)
    for g, c in zip(got, corners, strict=True):
        np.testing.assert_allclose(g, np.array(c) * S3, atol=2e-3)


def test_direction_to_face_inverts_the_table(rng):
    size = 16
    dirs = cubemap.texel_directions(size)
    face, s, t = cubemap.direction_to_face(dirs)
    expect_face = np.broadcast_to(np.arange(6)[:, None, None], face.shape)
    np.testing.assert_array_equal(face, expect_face)
    c = (np.arange(size) + 0.5) / size
    np.testing.assert_allclose(s, np.broadcast_to(c[None, None, :], s.shape), atol=1e-12)
    np.testing.assert_allclose(t, np.broadcast_to(c[None, :, None], t.shape), atol=1e-12)


@pytest.mark.parametrize("size", [1, 2, 8, 64])
def test_solid_angles_sum_to_four_pi(size):
    assert 6 * cubemap.texel_solid_angles(size).sum() == pytest.approx(4 * np.pi, rel=1e-12)


def test_solid_angle_matches_numerical_integration():
    # dOmega = dA / (1 + x^2 + y^2)^(3/2) on the face plane at distance 1: midpoint rule, fine grid
    size, n = 4, 400
    omega = cubemap.texel_solid_angles(size)
    for j, i in [(0, 0), (1, 2), (3, 3)]:
        x0, y0 = -1 + 2 * i / size, -1 + 2 * j / size
        h = 2 / size / n
        x = x0 + (np.arange(n) + 0.5) * h
        y = y0 + (np.arange(n) + 0.5) * h
        xx, yy = np.meshgrid(x, y)
        numeric = np.sum(h * h / (1 + xx**2 + yy**2) ** 1.5)
        assert omega[j, i] == pytest.approx(numeric, rel=1e-5)


# docs/contract.md section 2, written out here: face -> (sc, tc) -> unnormalised direction
FACE_TABLE = [lambda sc, tc: (1, -tc, -sc), lambda sc, tc: (-1, -tc, sc), lambda sc, tc: (sc, 1, tc),
              lambda sc, tc: (sc, -1, -tc), lambda sc, tc: (sc, -tc, 1), lambda sc, tc: (-sc, -tc, -1)]


@pytest.mark.parametrize("rotation_deg", [0.0, 1.0, 20.0, -50.0])
def test_from_equirect_reads_each_texel_direction_in_mitsubas_convention(rotation_deg):
    """A ramp map (R = row index, G = column index) is reproduced exactly by bilinear lookups, so each texel
    reads back where its direction lands: R = v (H - 1), G = u W - 0.5, with u = atan2(x, -z) / 2 pi + the
    rotation / 360 (the map turned by +deg about +Y shows at u - deg / 360) and v = acos(y) / pi."""
    h, w, size = 33, 72, 8
    env = np.zeros((h, w, 3), np.float32)
    env[..., 0] = np.arange(h)[:, None]
    env[..., 1] = np.arange(w)[None, :]
    faces = cubemap.from_equirect(env, size, rotation_deg)
    checked = 0
    for f in range(6):
        for j in range(size):
            for i in range(size):
                sc, tc = 2 * (i + 0.5) / size - 1, 2 * (j + 0.5) / size - 1  # texel centre, row j is t
                x, y, z = np.asarray(FACE_TABLE[f](sc, tc), float) / np.linalg.norm(FACE_TABLE[f](sc, tc))
                u = (np.arctan2(x, -z) / (2 * np.pi) + rotation_deg / 360.0) % 1.0
                col = u * w - 0.5
                assert faces[f, j, i, 0] == pytest.approx(np.arccos(y) / np.pi * (h - 1), abs=1e-4)
                if 0.0 <= col <= w - 1:  # away from the seam, where G wraps from W - 1 to 0
                    assert faces[f, j, i, 1] == pytest.approx(col, abs=1e-4)
                    checked += 1
    assert checked > 0.9 * 6 * size * size


def test_box_mip_chain_keeps_the_mean_radiance(rng):
    faces = rng.random((6, 16, 16, 3)).astype(np.float32)
    chain = cubemap.mip_chain(faces)
    assert [c.shape[1] for c in chain] == [16, 8, 4, 2, 1]
    np.testing.assert_allclose(chain[1][2, 3, 4], faces[2, 6:8, 8:10].mean(axis=(0, 1)), rtol=1e-6)
    np.testing.assert_allclose(chain[-1][:, 0, 0], faces.mean(axis=(1, 2)), rtol=1e-5)
