"""The pinhole camera, shared by both renderers: look-at, vertical field of view.

One `Camera` gives the OpenGL view and projection matrices, Mitsuba's sensor `to_world`,
and the world-space ray through every pixel centre, so the two renderers cannot disagree
on axes, rows or the fov axis:

- look-at like gluLookAt: the camera looks from `origin` to `target`, `up` is +Y on screen;
- `fov_deg` is the *vertical* field of view (Mitsuba `fov_axis='y'`);
- pixel (row i, column j) has its centre at ((j + 0.5) / W, (i + 0.5) / H), row 0 at the top.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from scenes.environment.directions import normalize


@dataclass(frozen=True)
class Camera:
    origin: tuple[float, float, float] = (0.0, 0.0, 4.0)
    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov_deg: float = 30.0
    width: int = 256
    height: int = 256

    @property
    def aspect(self) -> float:
        return self.width / self.height

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Orthonormal (right, true_up, forward) in world space."""
        forward = normalize(np.subtract(self.target, self.origin))
        right = normalize(np.cross(forward, self.up))
        true_up = np.cross(right, forward)
        return right, true_up, forward

    def view_matrix(self) -> np.ndarray:
        """4x4 world -> eye (OpenGL: the camera looks down -Z, +Y up), like gluLookAt."""
        right, true_up, forward = self.basis()
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = right, true_up, -forward
        m[:3, 3] = -m[:3, :3] @ np.asarray(self.origin, dtype=np.float64)
        return m

    def projection_matrix(self, near: float, far: float) -> np.ndarray:
        """4x4 OpenGL perspective projection (gluPerspective) with the vertical fov."""
        f = 1.0 / np.tan(np.radians(self.fov_deg) / 2.0)
        m = np.zeros((4, 4))
        m[0, 0] = f / self.aspect
        m[1, 1] = f
        m[2, 2] = (far + near) / (near - far)
        m[2, 3] = 2.0 * far * near / (near - far)
        m[3, 2] = -1.0
        return m

    def depth_range(self, positions: Sequence[np.ndarray]) -> tuple[float, float]:
        """(near, far) for the projection: every vertex between them, the near plane as far out as it can go.

        With OpenGL's default depth range, window depth is (f / (f − n)) (1 − n / z) for eye depth z (this
        projection_matrix), whose slope is f n / ((f − n) z²): a buffer of b bits resolves z in steps of
        z² (f − n) / (f n 2^b), about z² / (n 2^b) when f ≫ n. The near plane sets the step. With a near plane
        of far × 1e-4 (4.6·10⁻⁴ for a bowl seen from 4.6 units) a 24-bit buffer steps by 2·10⁻³ at 4 units, and a
        back face 1–2.5·10⁻³ behind a front face, as where a bowl's rim meets its walls, can win the depth test
        and show black.

        - near: 0.9 × the least eye depth of any vertex. A triangle's eye depth is linear between its vertices,
          so no point of the meshes lies nearer and nothing visible is clipped. Where a vertex lies at or behind
          the camera (the camera inside an object's span, or a plane passing under it), a triangle may reach
          any depth down to 0 and near falls back to 10⁻⁴ of the greatest vertex distance below.
        - far: 1.01 × the greatest distance from the camera to a vertex (at least 1; a distance is at least the
          eye depth, so no vertex lies beyond it).
        """
        origin = np.asarray(self.origin, dtype=np.float64)
        forward = self.basis()[2]
        farthest, least_depth = 1.0, np.inf
        for p in positions:
            offsets = np.asarray(p, dtype=np.float64).reshape(-1, 3) - origin
            if len(offsets):
                farthest = max(farthest, float(np.linalg.norm(offsets, axis=1).max()))
                least_depth = min(least_depth, float((offsets @ forward).min()))
        near = 0.9 * least_depth if 0.0 < least_depth < np.inf else farthest * 1e-4
        return near, 1.01 * farthest

    def mitsuba_to_world(self) -> np.ndarray:
        """4x4 camera -> world for Mitsuba's `perspective` sensor.

        Mitsuba's camera looks down local +Z with +Y up and +X to the *left* on the film
        (its `look_at` builds the columns (left, up, forward, origin)); so +X_local = -right.
        """
        right, true_up, forward = self.basis()
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = -right, true_up, forward, self.origin
        return m

    def pixel_rays(self) -> np.ndarray:
        """Unit world directions (H, W, 3) through every pixel centre, row 0 at the top."""
        return self.subpixel_rays(1)[:, :, 0]

    def subpixel_rays(self, k: int) -> np.ndarray:
        """Unit world directions (H, W, k*k, 3) through a k x k grid of points in every pixel.

        Sub-sample (a, b) (row a, column b) of pixel (i, j) sits at ((j + (b + 0.5) / k) / W,
        (i + (a + 0.5) / k) / H); k = 1 is the pixel centre.
        """
        right, true_up, forward = self.basis()
        th = np.tan(np.radians(self.fov_deg) / 2.0)
        off = (np.arange(k) + 0.5) / k
        cols = (np.arange(self.width)[:, None] + off[None, :]) / self.width  # (W, k)
        rows = (np.arange(self.height)[:, None] + off[None, :]) / self.height  # (H, k)
        x = (cols * 2.0 - 1.0) * th * self.aspect
        y = (1.0 - rows * 2.0) * th
        d = (forward + x[None, :, None, :, None] * right + y[:, None, :, None, None] * true_up)  # (H, W, k, k, 3)
        return normalize(d.reshape(self.height, self.width, k * k, 3))

    def project(self, points: np.ndarray) -> np.ndarray:
        """Continuous pixel coordinates (..., 2) as (column, row) of world points, row 0 at the top."""
        right, true_up, forward = self.basis()
        p = np.asarray(points, dtype=np.float64) - np.asarray(self.origin)
        z = p @ forward
        th = np.tan(np.radians(self.fov_deg) / 2.0)
        x = (p @ right) / (z * th * self.aspect)
        y = (p @ true_up) / (z * th)
        return np.stack([(x + 1.0) / 2.0 * self.width, (1.0 - y) / 2.0 * self.height], axis=-1)
