"""The numpy half of hemisphere lighting: the environment reduced to two radiances.

Hemisphere lighting replaces the environment by a uniform sky (the mean radiance L_s of the upper
hemisphere, d.y > 0) and a uniform ground (L_g, the lower one). For a surface with unit normal n, the
irradiance from a uniform upper hemisphere of radiance L_s is L_s times the cosine-weighted solid angle
of the sky above the surface's tangent plane: integral over {d.y > 0, d.n > 0} of d.n dw, which is
pi (1 + n.y) / 2 (the sky's view factor of a plane tilted by acos(n.y); Modest, Radiative Heat
Transfer, the view factor of a tilted plane to the sky). The ground fills the rest of the cosine
lobe, pi - pi (1 + n.y) / 2 = pi (1 - n.y) / 2, so

    E(n) = pi [ (1 + n.y) / 2 L_s + (1 - n.y) / 2 g L_g ]

exactly, for these two uniform hemispheres, with g = [realtime.hemisphere] ground_scale. A turn of
the environment about +Y (the scene's rotation) moves no radiance between the hemispheres: L_s and L_g
are computed once per scene.
"""

from __future__ import annotations

import numpy as np

from scenes.environment.directions import equirect_directions, equirect_solid_angles


def sky_ground(radiance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(L_s, L_g): the solid-angle-weighted mean RGB radiance of an equirect map's upper (+Y) and lower
    hemispheres. Samples on the horizon (y = 0) count half to each."""
    h, w = radiance.shape[:2]
    y = equirect_directions(h, w)[..., 1]
    omega = equirect_solid_angles(h, w)
    up = np.where(y > 0, 1.0, np.where(y == 0, 0.5, 0.0)) * omega
    down = omega - up
    rgb = radiance.astype(np.float64).reshape(h, w, 3)
    sky = np.einsum("hw,hwc->c", up, rgb) / up.sum()
    ground = np.einsum("hw,hwc->c", down, rgb) / down.sum()
    return sky, ground
