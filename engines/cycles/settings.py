"""Cycles' render settings for a reference-like image: what Mitsuba's reference does, nothing more.

- CPU, `spp` samples per pixel, the given seed (not animated), no adaptive sampling, no denoising, no
  light-tree threshold (light_sampling_threshold 0), no clamping (sample_clamp_direct/indirect 0: Cycles
  clamps indirect samples at 10 by default), no glossy filter (blur_glossy 0), caustics on.
- Bounces: Mitsuba's max_depth counts path segments (2 = direct lighting: one surface between the camera and
  the environment), Cycles' max_bounces counts bounces after the first surface (0 = direct lighting: its
  next-event ray and its BSDF ray that meets the world, MIS-weighted), so max_bounces = max_depth - 2, for
  every kind of bounce.
- Film: box filter of width 1 pixel (Mitsuba's box rfilter: each sample's weight is 1 inside its pixel),
  exposure 1 (Cycles' film_exposure multiplies the image), not transparent (the environment shows);
  exactly width x height at 100 %, square pixels.
- Colour: view transform Standard, look None, exposure 0, gamma 1; the OpenEXR output is scene linear
  whatever the view transform (a test renders with AgX and compares), RGB float32, ZIP.
"""

from __future__ import annotations

from engines.cycles.exported import View


def bounces(max_depth: int) -> int:
    """Cycles' max_bounces of Mitsuba's max_depth (see the module docstring)."""
    return max(int(max_depth) - 2, 0)


def configure(bpy, view: View, spp: int, seed: int, max_bounces: int, threads: int = 0,
              view_transform: str = "Standard") -> None:
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = int(spp)
    cycles.seed = int(seed)
    cycles.use_animated_seed = False
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.use_preview_denoising = False
    cycles.sampling_pattern = "TABULATED_SOBOL"
    cycles.light_sampling_threshold = 0.0
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0
    cycles.blur_glossy = 0.0
    cycles.caustics_reflective = cycles.caustics_refractive = True
    cycles.max_bounces = cycles.diffuse_bounces = cycles.glossy_bounces = max_bounces
    cycles.transmission_bounces = cycles.volume_bounces = cycles.transparent_max_bounces = max_bounces
    cycles.min_light_bounces = cycles.min_transparent_bounces = 0
    cycles.pixel_filter_type = "BOX"
    cycles.filter_width = 1.0
    cycles.film_exposure = 1.0
    render = scene.render
    render.resolution_x, render.resolution_y = int(view.width), int(view.height)
    render.resolution_percentage = 100
    render.pixel_aspect_x = render.pixel_aspect_y = 1.0
    render.use_border = False
    render.use_compositing = False
    render.use_sequencer = False
    render.film_transparent = False
    render.threads_mode = "FIXED" if threads > 0 else "AUTO"
    if threads > 0:
        render.threads = int(threads)
    scene.view_settings.view_transform = view_transform
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    image = render.image_settings
    image.file_format = "OPEN_EXR"
    image.color_mode = "RGB"
    image.color_depth = "32"
    image.exr_codec = "ZIP"
