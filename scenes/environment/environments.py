"""Builtin environments: four real light probes and five procedural maps.

Probes (files in scenes/data/envs, credits in its README): uffizi, ennis, pisa, wells.

Procedural maps, generated deterministically (no randomness) in the equirect convention:
- `constant`: radiance 1 everywhere (the white furnace: E = pi, a diffuse kd sphere shows kd).
- `studio`: four soft rectangular light boxes of radiance 20 on a dim 0.02 background
  (dynamic range 1e3), the look of a photo studio.
- `sky`: a vertical gradient sky, a dim ground, and a sun disk whose radiance is `sun` times
  the zenith sky radiance (up to 1e6): the hard case for SH ringing and Monte Carlo noise.
- `checker`: a high-frequency checkerboard (`cells` checks from pole to pole) for filtering tests.
- `calibration`: a sky with five coloured discs and no symmetry, on which each convention mistake leaves
  its own mark (scenes/environment/calibration.py; `iblcheck diagnose`).
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources

import numpy as np

from scenes.environment import envmap
from scenes.environment.calibration import calibration_map
from scenes.environment.directions import equirect_directions, uv_to_direction
from scenes.storage.errors import SceneError

PROBES = ("uffizi", "ennis", "pisa", "wells")

#: Allowed parameters per procedural map: name -> (default, min, max).
PARAMS: dict[str, dict[str, tuple[float, float, float]]] = {
    "constant": {"radiance": (1.0, 0.0, 1e9)},
    "studio": {},
    "sky": {
        "sun": (1e3, 0.0, 1e6),
        "sun_elevation_deg": (45.0, -90.0, 90.0),
        "sun_azimuth_deg": (30.0, -360.0, 360.0),
        "sun_radius_deg": (2.0, 0.05, 45.0),
    },
    "checker": {"cells": (16.0, 1.0, 512.0), "low": (0.1, 0.0, 1e9), "high": (1.0, 0.0, 1e9)},
    "calibration": {},
}
for _probe in PROBES:
    PARAMS[_probe] = {}

NAMES = tuple(PARAMS)


def resolve_params(name: str, params: dict | None, where: str = "environment.params") -> dict[str, float]:
    """Fill defaults and validate a builtin map's parameters (SceneError names the key)."""
    if name not in PARAMS:
        raise SceneError(f"unknown builtin environment {name!r}; choose one of {', '.join(NAMES)}")
    allowed = PARAMS[name]
    params = dict(params or {})
    for key in params:
        if key not in allowed:
            raise SceneError(
                f"{where}.{key}: unknown parameter for builtin:{name}; "
                + (f"allowed: {', '.join(allowed)}" if allowed else "it takes no parameters")
            )
    out = {}
    for key, (default, lo, hi) in allowed.items():
        value = params.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (lo <= value <= hi):
            raise SceneError(f"{where}.{key} = {value!r}: must be a number in [{lo:g}, {hi:g}]")
        out[key] = float(value)
    return out


def probe_path(name: str):
    return resources.files("scenes").joinpath(f"data/envs/{name}.hdr")


def builtin(name: str, params: dict | None = None) -> np.ndarray:
    """The (H, W, 3) float32 radiance of a builtin environment (read-only, cached)."""
    resolved = resolve_params(name, params)
    return _builtin_cached(name, tuple(sorted(resolved.items())))


@lru_cache(maxsize=32)
def _builtin_cached(name: str, params: tuple) -> np.ndarray:
    p = dict(params)
    if name in PROBES:
        with resources.as_file(probe_path(name)) as path:
            arr = envmap.read(path)
    elif name == "constant":
        arr = np.full((32, 64, 3), p["radiance"], dtype=np.float32)
    elif name == "studio":
        arr = _studio()
    elif name == "sky":
        arr = _sky(**p)
    elif name == "calibration":
        arr = calibration_map()
    else:
        arr = _checker(int(p["cells"]), p["low"], p["high"])
    arr = np.ascontiguousarray(arr, dtype=np.float32)
    arr.setflags(write=False)
    return arr


def _smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _studio(height: int = 128, width: int = 256) -> np.ndarray:
    d = equirect_directions(height, width)
    img = np.full((height, width, 3), 0.02)
    # (direction of the box centre, half-size in radians, radiance RGB)
    boxes = [
        ((0.6, 0.7, 0.4), 0.30, (20.0, 19.0, 18.0)),  # key light, upper right front
        ((-0.8, 0.4, 0.3), 0.22, (12.0, 12.5, 14.0)),  # fill light, left
        ((0.0, 0.95, -0.3), 0.35, (8.0, 8.0, 8.0)),  # overhead
        ((0.2, 0.2, -1.0), 0.18, (15.0, 14.0, 12.0)),  # rim light, behind
    ]
    for centre, half, rgb in boxes:
        c = np.asarray(centre) / np.linalg.norm(centre)
        # a tangent frame around the centre: the box is square in angle on that frame
        t1 = np.cross(c, [0.0, 1.0, 0.0]) if abs(c[1]) < 0.99 else np.array([1.0, 0.0, 0.0])
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(t1, c)
        z = d @ c
        a = np.abs(np.arctan2(d @ t1, z))
        b = np.abs(np.arctan2(d @ t2, z))
        w = (z > 0) * _smoothstep(half, half * 0.8, a) * _smoothstep(half, half * 0.8, b)
        img += w[..., None] * np.asarray(rgb)
    return img


def sun_direction(elevation_deg: float, azimuth_deg: float) -> np.ndarray:
    """Unit direction of the sun: azimuth measured like the map's u (0 = -Z, 90 = +X)."""
    return uv_to_direction(np.array(azimuth_deg / 360.0), np.array(0.5 - elevation_deg / 180.0))


def _sky(sun: float, sun_elevation_deg: float, sun_azimuth_deg: float, sun_radius_deg: float,
         height: int = 256, width: int = 512) -> np.ndarray:
    d = equirect_directions(height, width)
    y = d[..., 1]
    zenith = np.array([0.25, 0.45, 1.0])
    horizon = np.array([0.9, 0.95, 1.0])
    ground = np.array([0.12, 0.1, 0.08])
    t = np.clip(y, 0.0, 1.0)[..., None] ** 0.5
    img = np.where((y >= 0)[..., None], horizon * (1 - t) + zenith * t, ground)
    s = sun_direction(sun_elevation_deg, sun_azimuth_deg)
    angle = np.degrees(np.arccos(np.clip(d @ s, -1.0, 1.0)))
    # a disk with a one-pixel soft edge, so the sun survives resampling at any resolution
    edge = 180.0 / (height - 1)
    disk = _smoothstep(sun_radius_deg + edge / 2, sun_radius_deg - edge / 2, angle)
    img = img + disk[..., None] * sun * zenith.max() * np.array([1.0, 0.95, 0.85])
    return img


def _checker(cells: int, low: float, high: float, height: int = 128, width: int = 256) -> np.ndarray:
    rows = np.arange(height) * cells // height
    cols = np.arange(width) * (2 * cells) // width
    pattern = (rows[:, None] + cols[None, :]) % 2
    return np.repeat(np.where(pattern, high, low)[..., None], 3, axis=2)
