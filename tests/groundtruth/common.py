"""Small scenes and helpers for the ground-truth tests."""

from __future__ import annotations

import numpy as np

import scenes
from experiments.measure import metrics
from tests.helpers import sphere_scene_text, write_scene


def furnace_scene(tmp_path, material: str, size: int = 32, spp: int = 64, integrator: str = "auto",
                  resolution: int = 256) -> scenes.Scene:
    """A unit sphere in a constant environment of radiance 1, seen from z = 4.

    The sphere is finely tessellated (256 x 128 quads): in Mitsuba, light directions below a
    facet's plane but above the interpolated normal's horizon are blocked by the mesh itself (the
    shadow terminator), which costs a wide lobe ~0.3% at the default 64 x 32 and ~0.05% here.
    """
    text = sphere_scene_text("furnace", 'map = "builtin:constant"\nparams = { radiance = 1.0 }', material, size,
                             object_lines=f"resolution = {resolution}",
                             tables=f'[reference]\nspp = {spp}\nintegrator = "{integrator}"')
    return scenes.load(write_scene(tmp_path, text))


def small(name: str, size: int = 48, spp: int = 64, **overrides) -> scenes.Scene:
    base = {"camera.width": size, "camera.height": size, "reference.spp": spp}
    return scenes.load(name).with_overrides({**base, **overrides})


def masked_psnr(scene, a, b) -> float:
    mask = metrics.common_mask(a.mask, b.mask)
    return metrics.psnr(metrics.display(scene, a.rgb), metrics.display(scene, b.rgb), mask)


def pixel_sigma(r1, r2, mask) -> np.ndarray:
    """Per-channel standard deviation of one render's pixel noise, from two independent renders."""
    return np.std((r1.rgb - r2.rgb)[mask], axis=0) / np.sqrt(2.0)


def horizon_fraction(cos_nr: np.ndarray, exponent: float, steps: int = 4000) -> np.ndarray:
    """Fraction of the normalised Phong lobe about r above the horizon of n, for cos(n, r).

    In the lobe's frame (alpha, phi) about r, a direction is above the horizon of n when
    cos(alpha) cos(t) + sin(alpha) sin(t) cos(phi) > 0, t = angle(n, r): a fraction acos(-cot(alpha) cot(t)) / pi
    of phi; the lobe's CDF in u = cos^(N+1)(alpha) is uniform, so the mean over u is the midpoint rule below."""
    u = (np.arange(steps) + 0.5) / steps  # midpoint rule in the lobe's CDF variable
    cos_a = u ** (1.0 / (exponent + 1.0))
    sin_a = np.sqrt(np.maximum(0.0, 1 - cos_a**2))
    c = np.clip(cos_nr, -1, 1)[..., None]
    s = np.sqrt(np.maximum(0.0, 1 - c**2))
    with np.errstate(divide="ignore", invalid="ignore"):
        x = -(cos_a * c) / (sin_a * s)
    x = np.where(np.isfinite(x), x, np.where(cos_a * c > 0, -np.inf, np.inf))
    return (np.arccos(np.clip(x, -1, 1)) / np.pi).mean(axis=-1)
