"""One place that composes a real-time frame from the scene's techniques (docs/contract.md section 9).

    render(scene) -> Render

Once per scene: the techniques for the scene's effects are chosen and prepared (`precompute`, ms).
Per frame (the paper refilters every frame for dynamic lighting): the environment's cube map (or the
2D map of `realtime.parameterization`, realtime/engine/environment_maps.py) and its 2x2 box chain are
rebuilt, then every technique's `update` runs; `filter` is the cube map + chain + the techniques
whose timing key is `filter` (the paper's SH projection), other techniques have their own keys
(`irradiance`, `prefilter`, ...); then the shading pass (`draw`). `total` is the sum of the per-frame
keys and `draw`. The environment behind the objects is timed apart as `background` (it is
not part of any method and is masked out of metrics). Timings are medians and p90 over
`realtime.timing_frames` frames after `realtime.warmup_frames` warm-up frames (docs/contract.md section 7).
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from realtime.engine import levels, limits, technique
from realtime.engine.context import get_context, is_software, renderer_name
from realtime.engine.environment_maps import environment_store
from realtime.engine.gpu import SceneDrawer
from realtime.engine.technique import UnsimulatedEffectWarning  # noqa: F401 (where warnings are filtered)
from realtime.engine.timing import summarize, timed
from scenes import InputError
from scenes.model.render import Render


def object_distance(scene) -> float:
    """Distance from the camera to the nearest object's centre (drives `face_size = "auto"`)."""
    origin = np.asarray(scene.camera.origin, dtype=np.float64)
    centres = [obj.mesh.positions.astype(np.float64).mean(axis=0) for obj in scene.objects]
    return float(min(np.linalg.norm(c - origin) for c in centres))


def warn_unsimulated(scene) -> list[str]:
    """The scene's unsimulated effects, with one warning line when there are any."""
    missing = technique.unsimulated_effects(scene)
    if missing:
        warnings.warn(f"{scene.name}: the scene calls for {', '.join(missing)}, which the chosen real-time "
                      "techniques do not simulate; its error includes the missing effect",
                      technique.UnsimulatedEffectWarning, stacklevel=3)
    return missing


class TechniqueNotRunWarning(UserWarning):
    """A technique the scene chose does not run: the scene calls for no such effect, or it has no work."""


def warn_not_run(scene, idle: dict[str, str]) -> None:
    """One warning line for the scene's chosen techniques that do not run ({effect key: reason})."""
    if idle:
        rt = scene.realtime
        parts = "; ".join(f"realtime.{key} = {getattr(rt, key)!r}: {reason}" for key, reason in idle.items())
        warnings.warn(f"{scene.name}: {parts}: not run (the render's techniques record it under not_run)",
                      TechniqueNotRunWarning, stacklevel=3)


def render(scene) -> Render:
    """Render a scene in real time with its techniques; see the module docstring."""
    rt = scene.realtime
    if rt.renderer != "opengl":
        raise InputError(f"{scene.path or scene.name}: realtime.renderer = {rt.renderer!r}: this scene is rendered "
                         "by an external engine ([realtime.command]), not by iblcheck's OpenGL renderer; "
                         "`iblcheck render`, `compare`, `gate` and `sweep` run it")
    ctx = get_context()
    missing = warn_unsimulated(scene)
    distance = object_distance(scene)
    face_size = levels.select_face_size(rt.face_size, distance, rt.base_size)
    level = levels.level_of(face_size, rt.base_size)
    env_filter = environment_store(ctx, scene)  # realtime.parameterization: cube (the paper's) or a 2D map
    frame = technique.Frame(ctx, scene, env_filter, face_size, level, scene.environment.rotation_deg)
    techniques: list[technique.Technique] = []
    drawer = None
    try:
        t0 = time.perf_counter()
        techniques = technique.choose(scene, frame)
        idle = technique.not_run(scene)
        idle.update((t.declaration.effect, "its technique has no work in this scene")
                    for t in technique.without_work(techniques, frame))
        techniques = [t for t in techniques if t.declaration.effect not in idle]
        warn_not_run(scene, idle)
        for t in techniques:
            limits.clear_errors(ctx)  # the previous stage checked its own
            t.prepare(frame)
            key = t.declaration.effect
            limits.check_created(ctx, f"realtime.{key} = {getattr(rt, key)!r}", "the resources of its technique")
        ctx.finish()
        precompute_ms = (time.perf_counter() - t0) * 1e3
        needs = [t.chain_level(frame) for t in techniques]
        chain_to = None if None in needs else max(needs, default=level)
        needs_cube = not needs or any(n != technique.NO_CUBE for n in needs)
        drawer = SceneDrawer(ctx, scene, env_filter, techniques)

        def environment(rotation: float) -> None:
            if needs_cube:  # the light array alone reads the equirect map directly
                env_filter.fill_base(rotation)
                env_filter.build_chain(chain_to)

        keys = ["filter", *dict.fromkeys(k for t in techniques for k in (t.timing_key, *t.extra_timing_keys)
                                         if k != "filter")]
        samples: dict[str, list[float]] = {k: [] for k in (*keys, "draw", "total", "background")}
        for k in range(rt.warmup_frames + rt.timing_frames):
            frame.rotation_deg = scene.environment.rotation_deg + k * rt.rotate_deg_per_frame
            frame.number = k
            parts = dict.fromkeys(keys, 0.0)
            parts["filter"] = timed(ctx, lambda: environment(frame.rotation_deg))
            for t in techniques:
                parts[t.timing_key] += timed(ctx, lambda t=t: t.update(frame))
                for key, ms in t.split_timings().items():  # e.g. VCT's `mip` out of its `voxelize`
                    parts[key] += ms
                    parts[t.timing_key] -= ms
            t_background = timed(ctx, lambda: drawer.draw_background(frame.rotation_deg))
            t_draw = timed(ctx, drawer.draw)
            if k >= rt.warmup_frames:
                for key, value in parts.items():
                    samples[key].append(value)
                samples["draw"].append(t_draw)
                samples["total"].append(sum(parts.values()) + t_draw)
                samples["background"].append(t_background)
        # the image itself: the scene's own environment rotation
        frame.rotation_deg = scene.environment.rotation_deg
        frame.number = rt.warmup_frames + rt.timing_frames
        environment(frame.rotation_deg)
        for t in techniques:
            t.update(frame)
        drawer.draw_background(frame.rotation_deg)
        drawer.draw()
        rgb, mask = drawer.read()
        meta = {
            "renderer": "realtime",
            "gl": renderer_name(),
            "software_gl": is_software(),
            "face_size": face_size,
            "level": level,
            "base_size": rt.base_size,
            "object_distance": distance,
            "effects": sorted(scene.effects),
            "techniques": {**technique.describe(scene), **({"not_run": idle} if idle else {})},
            "unsimulated_effects": missing,
            "defines": list(drawer.defines),
            "frames": rt.timing_frames,
            "warmup_frames": rt.warmup_frames,
        }
        meta.update(env_filter.meta())
        for t in techniques:
            meta.update(t.meta())
        timings = summarize(samples)
        timings["precompute"] = precompute_ms
        return Render(rgb=rgb, mask=mask, timings=timings, meta=meta)
    finally:
        for t in techniques:
            t.release()
        if drawer is not None:
            drawer.release()
        env_filter.release()
