"""Mitsuba 3 references: `render(scene, spp, seed) -> Render`, cached (see cache.py).

Two passes per reference:
1. the image: the scene's integrator (mitsuba_scene.py) with the environment visible, RGBA;
2. coverage: a `direct` integrator with `hide_emitters = True`, whose alpha is the fraction of each
   pixel's samples that hit an object (Mitsuba's alpha in pass 1 is 1 wherever
   the environment shows, so it is no mask). A pixel is covered when at least half of it is.

`render_pair` adds a second render with another seed, for the noise floor (docs/contract.md section 7).
"""

from __future__ import annotations

import time

import numpy as np

from groundtruth.pathtracer import mitsuba_scene, paper_bsdf
from groundtruth.pathtracer import reference_cache as cache
from groundtruth.pathtracer.variant import mitsuba
from scenes.model.render import Render

COVERAGE_SPP = 16
#: alpha = fraction of a pixel's samples that hit an object. (`path` with max_depth = 1 would be
#: cheaper, but its scalar variant leaves alpha at 0; one light sample per hit works in all variants.)
COVERAGE_INTEGRATOR = {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0, "hide_emitters": True}


def second_seed(seed: int) -> int:
    """The seed of the noise-floor render: far from `seed` so that seed sweeps do not collide."""
    return (seed + 0x9E3779B1) % (2**31 - 1)


def render(scene, spp: int | None = None, seed: int | None = None, use_cache: bool = True) -> Render:
    """Path-traced reference of `scene` (`reference.spp` and `reference.seed` unless given)."""
    mi = mitsuba()
    spp = int(spp if spp is not None else scene.reference.spp)
    seed = int(seed if seed is not None else scene.reference.seed)
    env = scene.environment.radiance()
    integrator = mitsuba_scene.integrator_kind(scene)
    variant = mi.variant()
    key = cache.reference_key(scene, env, spp, seed, variant, mi.__version__, paper_bsdf.PLUGIN_VERSION, integrator)
    t0 = time.perf_counter()
    if not use_cache:
        return _render_now(mi, scene, env, spp, seed, integrator, key, "disabled")
    with cache.locked(key):
        entry = cache.load(key)
        if entry is not None:
            rgb, mask, meta = entry
            meta = {**meta, "cache": "hit"}
            timings = {"render": float(meta["render_ms"]), "load": (time.perf_counter() - t0) * 1e3}
            return Render(rgb=rgb, mask=mask.astype(bool), timings=timings, meta=meta)
        status = "corrupt" if (cache.cache_dir() / f"{key}.npz").exists() else "miss"
        result = _render_now(mi, scene, env, spp, seed, integrator, key, status)
        stored_meta = {k: v for k, v in result.meta.items() if k != "cache"}
        cache.store(key, result.rgb, result.mask, stored_meta)
        return result


def render_pair(scene, spp: int | None = None, seed: int | None = None) -> tuple[Render, Render]:
    """The reference and a second, independent render of it (another seed) for the noise floor."""
    seed = int(seed if seed is not None else scene.reference.seed)
    return render(scene, spp, seed), render(scene, spp, second_seed(seed))


def _render_now(mi, scene, env: np.ndarray, spp: int, seed: int, integrator: str, key: str, status: str) -> Render:
    t0 = time.perf_counter()
    mscene = mitsuba_scene.build(mi, scene, env, spp, seed)
    image = np.array(mi.render(mscene, spp=spp, seed=seed), dtype=np.float32)
    t1 = time.perf_counter()
    coverage = mi.load_dict(COVERAGE_INTEGRATOR)
    alpha = np.array(mi.render(mscene, integrator=coverage, spp=COVERAGE_SPP, seed=seed), dtype=np.float32)[..., 3]
    t2 = time.perf_counter()
    rgb = np.ascontiguousarray(image[..., :3])
    bad = ~np.isfinite(rgb)
    if bad.any():
        r, c, _ = np.argwhere(bad)[0]
        raise FloatingPointError(f"{scene.name}: the Mitsuba reference has {int(bad.sum())} NaN/Inf values "
                                 f"(first at row {r}, column {c}); variant {mi.variant()}")
    meta = {
        "renderer": "reference",
        "variant": mi.variant(),
        "mitsuba": mi.__version__,
        "plugin_version": paper_bsdf.PLUGIN_VERSION,
        "model": scene.reference.model,
        "integrator": integrator,
        "max_depth": mitsuba_scene.integrator_dict(scene)["max_depth"],
        "spp": spp,
        "seed": seed,
        "coverage_spp": COVERAGE_SPP,
        "key": key,
        "cache": status,
        "render_ms": (t1 - t0) * 1e3,
    }
    timings = {"render": (t1 - t0) * 1e3, "coverage": (t2 - t1) * 1e3}
    return Render(rgb=rgb, mask=alpha >= 0.5, timings=timings, meta=meta)
