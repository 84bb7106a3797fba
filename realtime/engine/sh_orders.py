"""SH projection and irradiance of orders 2..8 on the GPU (docs/contract.md section 9, `diffuse = "sh"`,
`sh_order` 2..4; `diffuse = "prt"`, `[realtime.prt] order` 2..8).

The paper's SH9 path (`EnvironmentFilter.project_sh`: sh_project.comp, sh_reduce.comp, the matrices M)
stays as it is. This module projects a level of the same cube map onto (order + 1)^2 coefficients
(sh_project_n.comp, sh_reduce_n.comp, basis in sh_basis.glsl with the constants of
`scenes.environment.shbasis.glsl_defines`) and writes, per coefficient k of band l,

    coeffs[k]   = sigma_l L_k           (windowed projection, as `deringing.apply` gives)
    weighted[k] = A_l sigma_l L_k       (A_l = R&H 2001 clamped-cosine factors, COSINE_BAND_FACTORS)

into one SSBO (`ShProjector.buffer`, std430 `vec4 coeffs[SH_COUNT]; vec4 weighted[SH_COUNT];`), so a
shader that includes sh_basis.glsl computes the irradiance with one basis evaluation:

    float y[SH_COUNT]; sh_eval(n, y);  E = sum_k weighted[k].rgb * y[k]    (E = pi for radiance 1)

`irradiance_weights` is the numpy reference of `weighted`.

Limits at order 8 (81 coefficients): the result is an SSBO (2 x 81 vec4 = 2.6 KiB; no uniform block), the
partial sums SSBO holds 81 vec4 per workgroup, and each workgroup sums its 64 invocations' 81 RGB values
through shared memory 25 coefficients at a time (sh_workgroup_sum.glsl: 25.6 KiB, under GL's guaranteed
32 KiB; all 81 at once would need 83 KiB). Each invocation keeps its 81 RGB sums and 81 basis values in
registers (private memory on llvmpipe).
"""

from __future__ import annotations

import moderngl
import numpy as np

from realtime.engine.gpu import groups, shader_source
from scenes.environment import cubemap
from scenes.environment.shbasis import COSINE_BAND_FACTORS, MAX_ORDER, band_of, count, glsl_defines, order_of

#: SSBO binding of the partial sums (pass 1 -> pass 2) and of the result (pass 2 -> shading)
PARTIALS_BINDING, RESULT_BINDING = 1, 2
#: texture unit the solid-angle texture is bound to while projecting
SOLID_ANGLE_UNIT = 1


def irradiance_weights(coeffs: np.ndarray, order: int | None = None, window=None) -> np.ndarray:
    """Reconstruction weights A_l sigma_l L_k ((order + 1)^2, C): E(n) = sum_k w_k Y_k(n).

    `coeffs` are the unwindowed coefficients of that order; `window` the per-band factors sigma_l
    (order + 1,), default none (all 1). A_l: `scenes.environment.shbasis.COSINE_BAND_FACTORS`.
    """
    coeffs = np.asarray(coeffs, dtype=np.float64)
    inferred = order_of(len(coeffs))
    if order is not None and order != inferred:
        raise ValueError(f"{len(coeffs)} coefficients are order {inferred}, not {order}")
    sigma = np.ones(inferred + 1) if window is None else np.asarray(window, dtype=np.float64)
    if sigma.shape != (inferred + 1,):
        raise ValueError(f"order {inferred} needs {inferred + 1} window factors, got shape {sigma.shape}")
    band = band_of(inferred)
    return coeffs * (COSINE_BAND_FACTORS[band] * sigma[band])[:, None]


class ShProjector:
    """Projects one level of a cube map (rgba32f, e.g. `EnvironmentFilter.cube`) onto SH of `order`.

    run(cube, level, face_size, window) dispatches both passes (no read-back); `buffer` then holds
    coeffs and weighted (see the module docstring) for binding at RESULT_BINDING; read() returns them.
    """

    def __init__(self, ctx: moderngl.Context, order: int) -> None:
        if not 2 <= order <= MAX_ORDER:
            raise ValueError(f"SH order must be 2..{MAX_ORDER}, got {order}")
        self.ctx = ctx
        self.order = order
        self.count = count(order)
        self.defines = glsl_defines(order)
        self.project_prog = ctx.compute_shader(shader_source("sh_project_n.comp", self.defines))
        self.reduce_prog = ctx.compute_shader(shader_source("sh_reduce_n.comp", self.defines))
        self.buffer = ctx.buffer(reserve=2 * self.count * 16)  # vec4 coeffs[n]; vec4 weighted[n]
        self._solid_angle: dict[int, moderngl.Texture] = {}
        self._partials: dict[int, moderngl.Buffer] = {}

    def _solid_angle_texture(self, face_size: int) -> moderngl.Texture:
        tex = self._solid_angle.get(face_size)
        if tex is None:
            omega = cubemap.texel_solid_angles(face_size).astype("f4")  # exact, computed in float64
            tex = self.ctx.texture((face_size, face_size), 1, omega.tobytes(), dtype="f4")
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self._solid_angle[face_size] = tex
        return tex

    def run(self, cube_texture: moderngl.TextureCube, level: int, face_size: int, window_factors=None) -> None:
        """Project mip `level` (faces face_size^2) of `cube_texture`; `window_factors` sigma_l, (order + 1,)."""
        base = cube_texture.size[0]
        if face_size != base >> level or face_size < 1:
            raise ValueError(f"level {level} of a {base}-texel cube has faces of {base >> level}, not {face_size}")
        sigma = np.ones(self.order + 1) if window_factors is None else np.asarray(window_factors, dtype=np.float64)
        if sigma.shape != (self.order + 1,):
            raise ValueError(f"order {self.order} needs {self.order + 1} window factors, got shape {sigma.shape}")
        block = max(1, min(4, face_size // 8))  # texels per invocation along each axis (as project_sh)
        tiles = groups(face_size, 8 * block)
        n_groups = 6 * tiles * tiles
        partial = self._partials.get(face_size)
        if partial is None:
            partial = self._partials[face_size] = self.ctx.buffer(reserve=n_groups * self.count * 16)
        cube_texture.bind_to_image(0, read=True, write=False, level=level)
        self._solid_angle_texture(face_size).use(SOLID_ANGLE_UNIT)
        self.project_prog["solid_angle"] = SOLID_ANGLE_UNIT
        self.project_prog["size"] = face_size
        self.project_prog["block"] = block
        project_and_reduce(self.ctx, self.project_prog, self.reduce_prog, partial, self.buffer, tiles, 6, n_groups,
                           sigma)

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """(coeffs (n, 3), weighted (n, 3)) as last computed, float64."""
        data = np.frombuffer(self.buffer.read(), dtype="f4").reshape(2, self.count, 4)[..., :3]
        return data[0].astype(np.float64), data[1].astype(np.float64)

    def release(self) -> None:
        for obj in [self.project_prog, self.reduce_prog, self.buffer, *self._solid_angle.values(),
                    *self._partials.values()]:
            obj.release()
        self._solid_angle.clear()
        self._partials.clear()


def project_and_reduce(ctx: moderngl.Context, project_prog, reduce_prog, partial, result, tiles: int, layers: int,
                       n_groups: int, sigma: np.ndarray) -> None:
    """The two passes of a GPU SH projection whose level, texel weights and uniforms are bound: per-workgroup
    partial sums into `partial`, then one workgroup reduces them, applies the band window `sigma` and
    writes coefficients and reconstruction weights into `result` (shared by the cube and the 2D maps)."""
    partial.bind_to_storage_buffer(PARTIALS_BINDING)
    project_prog.run(tiles, tiles, layers)
    ctx.memory_barrier()
    reduce_prog["n_groups"] = n_groups
    reduce_prog["window"].write(np.asarray(sigma, dtype="f4").tobytes())
    result.bind_to_storage_buffer(RESULT_BINDING)
    reduce_prog.run(1, 1, 1)
    ctx.memory_barrier()
