"""Cube-map seams: how much neighbouring texels differ across a face edge, against inside a face.

For a smooth map, a level whose texels are the filtered value at their own centre direction (a
prefiltered chain) changes across a face edge as much as one texel step inside the face does: the
ratio of the two is ~1 at every level. A chain whose texels are not values at their centres (2x2
box averages of a distorted grid, per face) shows a step at the edges that users see as seams
growing with blur. Pure numpy; faces (6, s, s, C) in the OpenGL face order (scenes.environment.cubemap).
"""

from __future__ import annotations

import numpy as np

from scenes.environment import cubemap


def edge_pairs(size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Index triples (face, row, col) of (edge texel, its neighbour across the edge, its neighbour inward).

    Every texel on a face's border is paired once per border side it lies on (4 sides x size x 6
    faces). The neighbour across is the texel of the adjacent face nearest to the point one texel
    step beyond the edge, in the edge texel's own face plane; the inward neighbour is one step back."""
    if size < 2:
        raise ValueError("faces of size 1 have no inside")
    c = cubemap.face_coords(size)
    step = 2.0 / size
    edge, across, inward = [], [], []
    k = np.arange(size)
    for face in range(6):
        # (col, row) of the edge texels and the (dcol, drow) pointing out of the face
        for cols, rows, dcol, drow in ((np.full(size, size - 1), k, 1, 0), (np.zeros(size, int), k, -1, 0),
                                       (k, np.full(size, size - 1), 0, 1), (k, np.zeros(size, int), 0, -1)):
            sc = c[cols] + dcol * step
            tc = c[rows] + drow * step
            f2, s2, t2 = cubemap.direction_to_face(cubemap.face_direction(face, sc, tc))
            i2 = np.clip((s2 * size).astype(np.int64), 0, size - 1)
            j2 = np.clip((t2 * size).astype(np.int64), 0, size - 1)
            edge.append(np.stack([np.full(size, face), rows, cols], axis=-1))
            across.append(np.stack([f2, j2, i2], axis=-1))
            inward.append(np.stack([np.full(size, face), rows - drow, cols - dcol], axis=-1))
    return np.concatenate(edge), np.concatenate(across), np.concatenate(inward)


def seam_residual(faces: np.ndarray) -> dict[str, float]:
    """Mean relative change per radian across face edges (`edge`) and one texel inward (`inside`), and
    `ratio` = edge / inside (~1 without seams; the per-radian scale removes the cube grid's own
    spacing, which is ~0.7x smaller across an edge than inward at face size 4).

    A step is |a - b| / ((|a| + |b|) / 2) / angle(a, b) per channel, averaged over channels and edge texels."""
    faces = np.asarray(faces, dtype=np.float64)
    size = faces.shape[1]
    dirs = cubemap.texel_directions(size)
    e, a, i = edge_pairs(size)

    def rel(p: np.ndarray, q: np.ndarray) -> float:
        x, y = faces[tuple(p.T)], faces[tuple(q.T)]
        angle = np.arccos(np.clip(np.sum(dirs[tuple(p.T)] * dirs[tuple(q.T)], axis=-1), -1.0, 1.0))
        step = 2.0 * np.abs(x - y) / np.maximum(np.abs(x) + np.abs(y), 1e-30)
        return float(np.mean(step / angle[:, None]))

    edge, inside = rel(e, a), rel(e, i)
    return {"edge": edge, "inside": inside, "ratio": edge / inside if inside > 0 else float("inf")}


def smooth_lobes(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A smooth map (a few wide exponential lobes on a floor) and its spherical Laplacian, per direction.

    For g = a exp(k (mu.w - 1)) with u = mu.w: Laplace-Beltrami g = k^2 (1 - u^2) g - 2 k u g."""
    f = np.full(d.shape[:-1], 0.2)
    lap = np.zeros(d.shape[:-1])
    for mu, k, a in (((0.3, 0.8, -0.5), 4.0, 1.0), ((-0.7, -0.2, 0.4), 8.0, 2.0), ((0.0, -1.0, 0.1), 2.0, 0.5)):
        mu = np.asarray(mu) / np.linalg.norm(mu)
        u = d @ mu
        g = a * np.exp(k * (u - 1.0))
        f = f + g
        lap = lap + g * (k * k * (1.0 - u * u) - 2.0 * k * u)
    return f, lap
