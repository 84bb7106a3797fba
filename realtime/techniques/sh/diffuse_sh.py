"""Diffuse technique `sh`: SH irradiance of the selected mip level (`realtime.diffuse = "sh"`).

Order 2 is the paper's method (Gu et al. 2006 after Ramamoorthi & Hanrahan 2001): nine coefficients
projected on the GPU (sh_project.comp, sh_reduce.comp) and E(n) = n^T M n. Orders 3 and 4 (16 and
25 coefficients, `realtime.sh_order`) project with sh_project_n.comp and reconstruct
E(n) = sum_lm A_l sigma_l L_lm Y_lm(n) with Ramamoorthi–Hanrahan's cosine band factors A_l
(pi, 2 pi / 3, pi / 4, 0, -pi / 24): since A_3 = 0, order 3 costs time and buys nothing.
The deringing window sigma_l (`realtime.sh_window`, realtime/techniques/sh/deringing.py) is chosen once from the
equirect map's own projection (a turn about +Y does not change the minimum of E) and applied to
every order.
"""

from __future__ import annotations

import moderngl

from realtime.engine import sh
from realtime.engine.environment_maps import MapShProjector
from realtime.engine.sh_orders import ShProjector
from realtime.engine.technique import Frame, Technique
from realtime.techniques.sh import deringing
from realtime.techniques.sh.deringing import min_irradiance
from scenes.environment import shbasis


class ShDiffuse(Technique):
    def __init__(self, frame: Frame) -> None:
        super().__init__(frame)
        self.order = frame.scene.realtime.sh_order
        self.window = None
        self.projector = None

    def prepare(self, frame: Frame) -> None:
        scene = frame.scene
        coeffs = sh.project_equirect(scene.environment.radiance(), scene.environment.rotation_deg, order=self.order)
        self.window = deringing.choose(scene.realtime.sh_window, coeffs)
        if self.order != 2 and scene.realtime.parameterization == "cube":
            self.projector = ShProjector(frame.ctx, self.order)
        elif self.order != 2:  # a 2D parameterization (realtime/engine/environment_maps.py)
            self.projector = MapShProjector(frame.ctx, self.order)

    def update(self, frame: Frame) -> None:
        if self.projector is None:
            frame.env_filter.project_sh(frame.face_size, self.window.factors)
        elif frame.env_filter.parameterization != "cube":
            self.projector.run(frame.env_filter, frame.level, frame.face_size, self.window.factors)
        else:
            self.projector.run(frame.env_filter.cube, frame.level, frame.face_size, self.window.factors)

    def defines(self) -> tuple[str, ...]:
        if self.order == 2:
            return ("DIFFUSE_SH9",)
        return ("DIFFUSE_SH_N", *shbasis.glsl_defines(self.order))

    def bind(self, prog: moderngl.Program) -> None:
        buffer = self.frame.env_filter.sh_buffer if self.projector is None else self.projector.buffer
        buffer.bind_to_storage_buffer(2)

    def coefficients(self):
        """The (windowed) coefficients (n, 3) last computed on the GPU."""
        if self.projector is None:
            return self.frame.env_filter.read_sh()[0]
        return self.projector.read()[0]

    def meta(self) -> dict:
        w = self.window
        coeffs = self.coefficients()
        return {"sh_order": self.order, "sh_coeffs": coeffs.tolist(),
                "sh_window": {"setting": self.frame.scene.realtime.sh_window, "kind": w.kind, "cutoff": w.cutoff,
                              "factors": list(w.factors), "min_irradiance_before": w.min_before,
                              "min_irradiance_after": w.min_after, "min_irradiance_gpu": min_irradiance(coeffs)}}

    def release(self) -> None:
        if self.projector is not None:
            self.projector.release()
