"""Writes pawn.glb and rook.stl beside this file: two chess pieces, generated here (no third-party
model ships with a permissive licence in the packages iblcheck installs). Run it from anywhere:

    .venv/bin/python scenes/data/meshes/make_models.py

- pawn.glb: a Staunton-style pawn, a lathe profile turned about its axis (trimesh.creation.revolve),
  modelled z-up the way CAD and DCC tools often export, with a root node that turns it y-up, scales it
  into the unit sphere and centres it (so reading it exercises glTF node transforms). Its NORMAL
  attribute holds smooth normals with hard edges where faces meet at more than 40 degrees, as a
  modelling tool exports them.
- rook.stl: a rook, a turned body and six box merlons on its rim, y-up, centred in the unit sphere,
  binary STL (facets only, no vertex normals: the scene picks them with objects.normals).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))  # the repository root, for scenes.geometry.meshes

from scenes.geometry import meshes  # noqa: E402

SECTIONS = 64


def _arc(centre: tuple[float, float], radius: float, start_deg: float, stop_deg: float, n: int) -> np.ndarray:
    a = np.radians(np.linspace(start_deg, stop_deg, n))
    return np.stack([centre[0] + radius * np.cos(a), centre[1] + radius * np.sin(a)], -1)


def pawn_profile() -> np.ndarray:
    """(radius, height) from the bottom centre to the top of the head, height 1.6."""
    body_z = np.linspace(0.34, 0.92, 10)
    body_r = 0.15 + 0.23 * ((0.92 - body_z) / 0.58) ** 2  # a concave taper
    return np.concatenate([
        [[0.0, 0.0], [0.55, 0.0], [0.55, 0.09]],  # the foot: a flat bottom and a vertical rim
        _arc((0.47, 0.09), 0.08, 0.0, 90.0, 6)[1:],  # a rounded shoulder
        [[0.40, 0.20]],
        _arc((0.40, 0.26), 0.06, -90.0, 90.0, 8)[1:],  # a bead
        np.stack([body_r, body_z], -1),
        [[0.30, 0.95], [0.30, 1.01], [0.14, 1.05]],  # the collar: sharp rims
        _arc((0.0, 1.30), 0.26, -58.0, 90.0, 14),  # the head, a ball on the neck
    ])


def rook_parts() -> list[trimesh.Trimesh]:
    """The turned body (z-up) and six merlon boxes on its rim."""
    body_z = np.linspace(0.34, 1.05, 8)
    body_r = 0.30 + 0.06 * ((1.05 - body_z) / 0.71) ** 2
    profile = np.concatenate([
        [[0.0, 0.0], [0.58, 0.0], [0.58, 0.10]],
        _arc((0.50, 0.10), 0.08, 0.0, 90.0, 6)[1:],
        [[0.42, 0.22], [0.42, 0.30]],
        np.stack([body_r, body_z], -1),
        [[0.40, 1.08], [0.40, 1.20], [0.0, 1.20]],  # the crown: a flat top
    ])
    parts = [trimesh.creation.revolve(profile, sections=SECTIONS)]
    for k in range(6):
        merlon = trimesh.creation.box(extents=[0.14, 0.20, 0.18])
        angle = 2 * np.pi * k / 6
        place = trimesh.transformations.rotation_matrix(angle, [0, 0, 1])
        place[:3, 3] = [0.31 * np.cos(angle), 0.31 * np.sin(angle), 1.20 + 0.09 - 0.005]
        merlon.apply_transform(place)
        parts.append(merlon)
    return parts


def fit_unit_sphere(points: np.ndarray) -> np.ndarray:
    """The 4x4 matrix that turns z-up into y-up (x, y, z) -> (x, z, -y), centres the bounding box and
    scales the farthest point to 0.999 (as the builtin shapes are)."""
    turn = trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0])
    p = points @ turn[:3, :3].T
    centre = (p.min(axis=0) + p.max(axis=0)) / 2
    scale = 0.999 / np.linalg.norm(p - centre, axis=1).max()
    fit = np.eye(4)
    fit[:3, :3] *= scale
    fit[:3, 3] = -centre * scale
    return fit @ turn


def write_pawn(path: Path) -> None:
    pawn = trimesh.creation.revolve(pawn_profile(), sections=SECTIONS)
    p, idx, n = meshes.smooth_shaded(np.asarray(pawn.vertices), np.asarray(pawn.faces), 40.0)
    shaded = trimesh.Trimesh(p, idx, vertex_normals=n, process=False)
    scene = trimesh.Scene()
    scene.add_geometry(shaded, node_name="pawn", geom_name="pawn", transform=fit_unit_sphere(p))
    path.write_bytes(scene.export(file_type="glb", include_normals=True))


def write_rook(path: Path) -> None:
    rook = trimesh.util.concatenate(rook_parts())
    rook.apply_transform(fit_unit_sphere(np.asarray(rook.vertices)))
    path.write_bytes(rook.export(file_type="stl"))


if __name__ == "__main__":
    write_pawn(HERE / "pawn.glb")
    write_rook(HERE / "rook.stl")
    for name in ("pawn.glb", "rook.stl"):
        m = meshes.load_file(HERE / name)
        print(f"{name}: {m.n_triangles} triangles, {len(m.positions)} vertices, closed {m.closed}, convex {m.convex}")
