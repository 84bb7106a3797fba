"""The method under test: Gu et al. 2006 in moderngl (design.md section 3).

    realtime.render(scene) -> Render

Per frame (the paper refilters every frame for dynamic lighting): cube map from the equirect
environment, 2x2 box mip chain, SH9 of the selected level and the matrices M (`filter`), then the
shading pass (`draw`); `total` = filter + draw. The environment drawn behind the objects is timed
apart as `background` (it is not part of the method and is masked out of metrics). Timings are
medians and p90 over `realtime.timing_frames` frames after `realtime.warmup_frames` warm-up
frames (design.md section 7).
"""

from __future__ import annotations

import numpy as np

from scenes.render import Render

from . import levels


def object_distance(scene) -> float:
    """Distance from the camera to the nearest object's centre (drives `face_size = "auto"`)."""
    origin = np.asarray(scene.camera.origin, dtype=np.float64)
    centres = [obj.mesh.positions.astype(np.float64).mean(axis=0) for obj in scene.objects]
    return float(min(np.linalg.norm(c - origin) for c in centres))


def render(scene) -> Render:
    """Render a scene with the paper's real-time method; see the module docstring."""
    from .context import get_context, is_software, renderer_name
    from .gpu import EnvironmentFilter, SceneDrawer
    from .timing import summarize, timed

    rt = scene.realtime
    ctx = get_context()
    effects = scene.effects
    distance = object_distance(scene)
    face_size = levels.select_face_size(rt.face_size, distance, rt.base_size)
    level = levels.level_of(face_size, rt.base_size)
    need_sh = "diffuse" in effects
    chain_to = None if "glossy" in effects else level  # glossy reads the whole chain

    env = scene.environment.radiance()
    window = None
    if need_sh:  # the deringing window, chosen once (a turn about +Y does not change min E)
        from . import deringing, sh

        window = deringing.choose(rt.sh_window, sh.project_equirect(env, scene.environment.rotation_deg))
    env_filter = EnvironmentFilter(ctx, env, rt.base_size)
    drawer = SceneDrawer(ctx, scene, env_filter)

    def filter_work(rotation: float) -> None:
        env_filter.fill_base(rotation)
        env_filter.build_chain(chain_to)
        if need_sh:
            env_filter.project_sh(face_size, window.factors)

    samples: dict[str, list[float]] = {"filter": [], "draw": [], "total": [], "background": []}
    try:
        for k in range(rt.warmup_frames + rt.timing_frames):
            rotation = scene.environment.rotation_deg + k * rt.rotate_deg_per_frame
            t_filter = timed(ctx, lambda r=rotation: filter_work(r))
            t_background = timed(ctx, lambda r=rotation: drawer.draw_background(r))
            t_draw = timed(ctx, lambda: drawer.draw(face_size))
            if k >= rt.warmup_frames:
                samples["filter"].append(t_filter)
                samples["draw"].append(t_draw)
                samples["total"].append(t_filter + t_draw)
                samples["background"].append(t_background)
        # the image itself: the scene's own environment rotation
        filter_work(scene.environment.rotation_deg)
        drawer.draw_background(scene.environment.rotation_deg)
        drawer.draw(face_size)
        rgb, mask = drawer.read()
        meta = {
            "renderer": "realtime",
            "gl": renderer_name(),
            "software_gl": is_software(),
            "face_size": face_size,
            "level": level,
            "base_size": rt.base_size,
            "object_distance": distance,
            "effects": sorted(effects),
            "defines": list(drawer.defines),
            "frames": rt.timing_frames,
            "warmup_frames": rt.warmup_frames,
        }
        if need_sh:
            from .deringing import min_irradiance

            coeffs, _ = env_filter.read_sh()
            meta["sh_coeffs"] = coeffs.tolist()
            meta["sh_window"] = {"setting": rt.sh_window, "kind": window.kind, "cutoff": window.cutoff,
                                 "factors": list(window.factors), "min_irradiance_before": window.min_before,
                                 "min_irradiance_after": window.min_after,
                                 "min_irradiance_gpu": min_irradiance(coeffs)}
        return Render(rgb=rgb, mask=mask, timings=summarize(samples), meta=meta)
    finally:
        drawer.release()
        env_filter.release()
