"""A model of the ideal read of an axis-aligned cone through level-0 voxel opacities (numpy): what the cone
model of voxel cone tracing reaches when every read is a box exactly as wide as the cone, centred on its axis,
each level-0 column composited exactly through it. The shading pass reads texels of the mip pyramid instead:
grid-aligned, power-of-two wide, capped near the surface the cone leaves, and kept no more open than the
axis's own column (vct_trace.glsl). docs/voxel-cone-tracing-measurements.md compares the two under a sphere
above a plane, where this model comes within the criterion's 3 points of the exact 11.1 % at 64^3 and the
shading's cones do not."""

from __future__ import annotations

import numpy as np

#: the opacity read is kept below 1 so that its optical depth stays finite (as vct_trace.glsl's VCT_MAX_ALPHA)
MAX_ALPHA = 0.999999


def ideal_axis_cone_occlusion(alpha: np.ndarray, voxel: float, grid_min: np.ndarray, origin: np.ndarray,
                              axis: int, sign: int, tan_half: float, t0: float, clear_from: float,
                              step: float = 0.5) -> float:
    """The occlusion of a cone from `origin` along sign e_axis (half-angle tan `tan_half`, first sample at
    distance `t0`) read through `alpha` (R, R, R) indexed [x, y, z]: the level-0 opacity of the faces that point
    against the cone, voxels of edge `voxel` from the grid's lower corner `grid_min`.

    At distance t the read is the box of width w = 2 t tan_half centred on the axis (depth w along it), shrunk
    so that its near side stays beyond `clear_from` along the axis (the surface the cone leaves and its own
    voxels lie before it): sign (p_axis - clear_from) >= w / 2. Its opacity a is the mean over the box's
    level-0 columns of 1 - prod(1 - alpha) along the axis, and a step ds = step w passes (1 - a)^(ds / depth),
    the box's depth being the voxels it spans along the axis (Beer-Lambert, as the shading's steps). The cone
    ends where its box leaves the grid. Returns 1 - the product of the steps' transmittances."""
    alpha = np.asarray(alpha, dtype=np.float64)
    res = alpha.shape[0]
    grid_min = np.asarray(grid_min, dtype=np.float64)
    origin = np.asarray(origin, dtype=np.float64)
    d = np.zeros(3)
    d[axis] = float(sign)
    lateral = [a for a in range(3) if a != axis]
    transmittance, t = 1.0, float(t0)
    while transmittance > 1e-6:
        p = origin + t * d
        w = 2.0 * t * tan_half
        w = min(w, 2.0 * sign * (p[axis] - clear_from))
        if w < voxel:  # still too near the surface for a box of one voxel: move on by one
            t += voxel
            continue
        lo = np.floor((p - 0.5 * w - grid_min) / voxel).astype(int)
        hi = np.ceil((p + 0.5 * w - grid_min) / voxel).astype(int)
        if lo[axis] < 0 or hi[axis] > res:
            break
        lo[lateral] = np.maximum(lo[lateral], 0)
        hi[lateral] = np.minimum(hi[lateral], res)
        box = alpha[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
        a = float(np.mean(1.0 - np.prod(1.0 - box, axis=axis)))
        ds = step * w
        transmittance *= (1.0 - min(a, MAX_ALPHA)) ** (ds / ((hi[axis] - lo[axis]) * voxel))
        t += ds
    return 1.0 - transmittance
