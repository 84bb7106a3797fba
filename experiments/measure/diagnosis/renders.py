"""The reference images the forward models start from: the scene re-rendered as a mistaken engine saw it.

    Renders(scene, renderer="reference")
        .base()                     the reference of the scene itself (its mask is the diagnosis' mask)
        .second()                   the other-seed reference (the noise floor), None for the quadrature
        .render(mistakes)           the reference of the scene with the scene-level mistakes, with the
                                    half-pixel footprint when `half_pixel` is in (linear RGB, float64)
        .proxy(mistakes, angle)     a cheap render for ranking environment angles

`renderer = "reference"` is Mitsuba (groundtruth.render: the scene's spp and seed, the disk cache);
`"quadrature"` the noise-free quadrature (groundtruth.exact.quadrature: unoccluded, so exact only for one
convex object). The half-pixel footprint comes from a render at twice the width and height (Mitsuba at
a quarter of the spp, the same samples per pixel in all; the quadrature with 2 x 2 instead of 4 x 4
sub-pixels), whose 2 x 2 blocks shifted by one sub-pixel are the shifted pixels exactly
(hypotheses.half_pixel_shift). The u-mirrored map is written once to the cache folder as an .exr
(float32, lossless) named by its content and given to the scene as environment.map: the scene model
needs no key for it.
"""

from __future__ import annotations

import hashlib
import math

import numpy as np

import groundtruth
from experiments.measure.diagnosis import hypotheses
from groundtruth.exact import quadrature
from groundtruth.pathtracer.reference import second_seed
from scenes import InputError
from scenes.environment import environments, envmap
from scenes.model.render import Render
from scenes.storage import imageio
from scenes.storage.disk_cache import cache_dir

RENDERERS = ("reference", "quadrature")
#: samples per pixel of the path-traced proxy that ranks environment angles (uncached): enough to tell a
#: disc from the sky, a sixteenth of a typical reference
PROXY_SPP = 4


class Renders:
    """Reference renders of one scene and its mistaken variants, each made once per diagnosis."""

    def __init__(self, scene, renderer: str = "reference"):
        if renderer not in RENDERERS:
            raise InputError(f"--reference {renderer!r}: choose one of {', '.join(RENDERERS)}")
        self.scene = scene
        self.renderer = renderer
        self._images: dict[tuple, np.ndarray] = {}
        self._proxies: dict[tuple, np.ndarray] = {}
        self._base: Render | None = None
        self._mirrored_map: str | None = None

    # ------------------------------------------------------------------ the scene as the engine saw it

    def variant(self, mistakes: dict):
        """The scene with the scene-level mistakes of `mistakes` made (env_rotation's angle, its value)."""
        s = self.scene
        overrides: dict = {}
        if "env_rotation" in mistakes:
            overrides["environment.rotation_deg"] = s.environment.rotation_deg + float(mistakes["env_rotation"])
        if "env_u_mirror" in mistakes:
            overrides["environment.map"] = self.mirrored_map()
            if s.environment.params:
                overrides["environment.params"] = {}
        if "fov_horizontal" in mistakes:
            c = s.camera
            overrides["camera.fov_deg"] = hypotheses.horizontal_fov_as_vertical(c.fov_deg, c.width, c.height)
        return s.with_overrides(overrides) if overrides else s

    def mirrored_map(self) -> str:
        """The path of the scene's map with u mirrored (unscaled: environment.scale still applies)."""
        if self._mirrored_map is None:
            env = self.scene.environment
            name = env.builtin_name
            raw = (environments.builtin(name, dict(env.params)) if name
                   else envmap.read(env.map, sanitize=env.sanitize))
            mirrored = hypotheses.mirror_u(raw).astype(np.float32)
            digest = hashlib.sha256(mirrored.tobytes() + repr(mirrored.shape).encode()).hexdigest()[:32]
            path = cache_dir() / "diagnosis" / f"u-mirrored-{digest}.exr"
            if not path.exists():
                path.parent.mkdir(parents=True, exist_ok=True)
                imageio.write_exr(path, mirrored)
            self._mirrored_map = str(path)
        return self._mirrored_map

    # ------------------------------------------------------------------ renders

    def _render(self, scene, supersampled: bool = False) -> Render:
        if supersampled:
            c = scene.camera
            scene = scene.with_overrides({"camera.width": 2 * c.width, "camera.height": 2 * c.height})
        if self.renderer == "quadrature":
            return quadrature.render(scene, subpixels=2 if supersampled else 4)
        spp = scene.reference.spp
        return groundtruth.render(scene, spp=math.ceil(spp / 4) if supersampled else spp)

    def base(self) -> Render:
        """The reference of the scene as it is."""
        if self._base is None:
            self._base = self._render(self.scene)
        return self._base

    def second(self) -> Render | None:
        """The reference with the other seed (its noise floor); None for the noise-free quadrature."""
        if self.renderer == "quadrature":
            return None
        return groundtruth.render(self.scene, seed=second_seed(self.scene.reference.seed))

    def render(self, mistakes: dict) -> np.ndarray:
        """(H, W, 3) float64 linear radiance of the scene with the scene-level and render-stage mistakes."""
        key = _scene_key(mistakes) + (("half_pixel" in mistakes),)
        if key not in self._images:
            scene_level = {k: v for k, v in mistakes.items() if k in hypotheses.SCENE_LEVEL}
            if "half_pixel" in mistakes:
                rgb = hypotheses.half_pixel_shift(self._render(self.variant(scene_level), supersampled=True).rgb)
            elif not scene_level:
                rgb = np.asarray(self.base().rgb, np.float64)
            else:
                rgb = np.asarray(self._render(self.variant(scene_level)).rgb, np.float64)
            self._images[key] = rgb
        return self._images[key]

    def proxy(self, mistakes: dict, angle_deg: float) -> np.ndarray:
        """A cheap render of the scene with `mistakes`' scene-level mistakes and the environment turned by
        `angle_deg`: Mitsuba at PROXY_SPP, uncached, the scene's seed (the same noise at every angle, so
        the ranking is smooth in the angle), or the quadrature with one ray per pixel."""
        scene_level = {k: v for k, v in mistakes.items() if k in hypotheses.SCENE_LEVEL}
        scene_level["env_rotation"] = angle_deg
        key = _scene_key(scene_level)
        if key not in self._proxies:
            scene = self.variant(scene_level)
            if self.renderer == "quadrature":
                rgb = quadrature.render(scene, subpixels=1).rgb
            else:
                rgb = groundtruth.render(scene, spp=min(PROXY_SPP, scene.reference.spp), use_cache=False).rgb
            self._proxies[key] = np.asarray(rgb, np.float64)
        return self._proxies[key]


def _scene_key(mistakes: dict) -> tuple:
    return tuple(sorted((k, round(float(v), 6) if k == "env_rotation" else None)
                        for k, v in mistakes.items() if k in hypotheses.SCENE_LEVEL))

