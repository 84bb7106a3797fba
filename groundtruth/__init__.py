"""Mitsuba 3 references of iblcheck scenes, and an independent noise-free quadrature.

    groundtruth.render(scene, spp=None, seed=None) -> Render      # path-traced, cached
    groundtruth.render_pair(scene)                  -> (Render, Render)  # for the noise floor
    groundtruth.exact.quadrature.render(scene)            -> Render      # exact, unoccluded

Mitsuba is imported lazily (variant.py chooses the variant and the libLLVM first).
"""

from groundtruth.exact import quadrature
from groundtruth.pathtracer.reference import render, render_pair

__all__ = ["quadrature", "render", "render_pair"]
