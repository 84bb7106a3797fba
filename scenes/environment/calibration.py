"""`builtin:calibration`: an environment on which every convention mistake leaves its own mark.

A smooth sky (a vertical gradient from a brown ground through a pale horizon to a blue zenith, times a
gentle warm-cool swing in azimuth) and five bright coloured discs at asymmetric azimuths and elevations.
Nothing in it is symmetric: no left-right mirror (u -> 1 - u moves every disc onto empty sky), no up-down
mirror (ground and sky differ), no rotation about +Y maps it onto itself (the azimuthal swing has one
period and the discs are at uneven spacings). So an image flipped in x or y, a map turned or u-mirrored,
a wrong field of view or a half-pixel shift each change the image of a mirror sphere and a diffuse sphere
in their own way (experiments/measure/diagnosis/).

The discs are bright (radiance 3 to 4, the sky 0.1 to 1.4) and wide (13 to 20 degrees), so that a diffuse
sphere lit by them converges at a few dozen samples per pixel, and each disc has a one-texel soft edge so
that it survives bilinear resampling at any map size.
"""

from __future__ import annotations

import numpy as np

from scenes.environment.directions import equirect_directions, uv_to_direction

#: (azimuth deg (0 = -Z, 90 = +X, as the map's u), elevation deg, angular radius deg, linear RGB radiance)
DISCS = (
    (25.0, 35.0, 16.0, (4.0, 0.6, 0.4)),  # red, front right, high
    (110.0, 5.0, 13.0, (0.5, 3.5, 0.6)),  # green, right, near the horizon
    (200.0, 50.0, 20.0, (0.5, 1.0, 4.0)),  # blue, behind, high
    (255.0, -30.0, 14.0, (3.5, 3.0, 0.4)),  # yellow, behind left, below the horizon
    (320.0, 12.0, 18.0, (3.0, 0.5, 3.0)),  # magenta, front left, low
)
ZENITH = np.array([0.25, 0.45, 1.0])
HORIZON = np.array([0.9, 0.85, 0.75])
GROUND = np.array([0.2, 0.13, 0.07])
#: the sky's azimuthal swing: radiance x (1 + SWING cos(azimuth - SWING_AZIMUTH_DEG))
SWING, SWING_AZIMUTH_DEG = 0.45, 60.0


def disc_direction(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """Unit direction of a disc centre in the map's frame (azimuth measured like u: 0 = -Z, 90 = +X)."""
    return uv_to_direction(np.array(azimuth_deg / 360.0), np.array(0.5 - elevation_deg / 180.0))


def calibration_map(height: int = 128, width: int = 256) -> np.ndarray:
    """The (height, width, 3) float64 radiance of `builtin:calibration` (deterministic)."""
    d = equirect_directions(height, width)
    y = d[..., 1]
    t = np.clip(y, 0.0, 1.0)[..., None] ** 0.6
    sky = HORIZON * (1.0 - t) + ZENITH * t
    # below the horizon: the horizon colour fades into the ground over 15 degrees
    g = np.clip(-y / np.sin(np.radians(15.0)), 0.0, 1.0)[..., None]
    img = np.where((y >= 0)[..., None], sky, HORIZON * (1.0 - g) + GROUND * g)
    azimuth = np.arctan2(d[..., 0], -d[..., 2])
    img = img * (1.0 + SWING * np.cos(azimuth - np.radians(SWING_AZIMUTH_DEG)))[..., None]
    edge = 180.0 / (height - 1)  # one texel in degrees: the discs' soft edge
    for az, el, radius, rgb in DISCS:
        angle = np.degrees(np.arccos(np.clip(d @ disc_direction(az, el), -1.0, 1.0)))
        cover = np.clip((radius + edge / 2 - angle) / edge, 0.0, 1.0)
        img = img * (1.0 - cover[..., None]) + cover[..., None] * np.asarray(rgb)
    return img
