"""Where voxel cone tracing's one bounce sits in the image, against the path tracer's: a figure and its numbers.

    .venv/bin/python benchmarks/vct_bounce_images.py [--scene torus-phong] [--pixels 192] [--subpixels 4]
                                                     [--spp 1024] [--resolutions 64,128]
                                                     [--out docs/images/vct-torus-bounce.png]

The one bounce of each renderer is its image with it minus its image without it, over the pixels every image
covers: VCT's `occlusion = interreflection = "vct"` minus `occlusion = "vct"` (one cascade, six cones, each pixel
the area mean of `--subpixels`^2 samples, as E10's energy table renders it), the path tracer's max_depth 3 minus
max_depth 2 at `--spp`. Prints per resolution the ratio of the means (E10's indirect energy) and the share of
each image's bounce that lies in pixels brighter than the path tracer's brightest one-bounce pixel: a bounce
with the right total but gathered into too few pixels shows there. Writes the images side by side, cropped to
the pixels that hold the path tracer's bounce, on one colour scale (the path tracer's brightest pixel).
Real-time images and references come from the caches where they are.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

import scenes
from experiments.paper.e10_voxel_cone_tracing import area_render, vct_ov
from experiments.publish.plots import pyplot, save
from groundtruth.pathtracer import reference


def one_bounce_images(spec: str, pixels: int, subpixels: int, spp: int,
                      resolutions: list[int]) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The grey one-bounce images, "path" and "VCT R^3" per resolution, and the mask every image covers."""
    scene = scenes.load(spec).with_overrides({"camera.width": pixels, "camera.height": pixels,
                                              "reference.spp": spp, "realtime.timing_frames": 1,
                                              "realtime.warmup_frames": 0})
    depth = {d: reference.render(scene.with_overrides({"reference.integrator": "path", "reference.max_depth": d}))
             for d in (2, 3)}
    images = {"path": (depth[3].rgb - depth[2].rgb).mean(-1)}
    mask = depth[2].mask & depth[3].mask
    for res in resolutions:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the effects left out: not what is measured
            occlusion = area_render(scene.with_overrides(vct_ov(res, 1, 6, False)), subpixels)
            bounce = area_render(scene.with_overrides(vct_ov(res, 1, 6, True)), subpixels)
        images[f"VCT {res}^3"] = (bounce.rgb - occlusion.rgb).mean(-1)
        mask &= occlusion.mask & bounce.mask
    return images, mask


def share_above(image: np.ndarray, mask: np.ndarray, level: float) -> float:
    """The share of the image's bounce (negative pixels, the noise of a difference, counted as 0) in pixels above
    `level`."""
    values = np.maximum(image[mask], 0.0)
    return float(values[values > level].sum() / values.sum())


def crop_box(image: np.ndarray, mask: np.ndarray, margin: int) -> tuple[slice, slice]:
    """Rows and columns around the pixels holding the brightest 90 % of the image's bounce, plus `margin`."""
    values = np.where(mask, np.maximum(image, 0.0), 0.0)
    order = np.sort(values.ravel())[::-1]
    level = order[np.searchsorted(np.cumsum(order), 0.9 * order.sum())]
    rows, cols = np.nonzero(values >= level)
    h, w = image.shape
    return (slice(max(rows.min() - margin, 0), min(rows.max() + margin + 1, h)),
            slice(max(cols.min() - margin, 0), min(cols.max() + margin + 1, w)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="torus-phong", help="a builtin scene's name, or a scene file")
    ap.add_argument("--pixels", type=int, default=192)
    ap.add_argument("--subpixels", type=int, default=4)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--resolutions", default="64,128")
    ap.add_argument("--out", type=Path, default=Path("docs/images/vct-torus-bounce.png"))
    args = ap.parse_args()
    resolutions = [int(r) for r in args.resolutions.split(",")]
    spec = args.scene if ":" in args.scene or args.scene.endswith(".toml") else f"builtin:{args.scene}"
    images, mask = one_bounce_images(spec, args.pixels, args.subpixels, args.spp, resolutions)
    path = images["path"]
    peak = float(path[mask].max())
    print(f"{args.scene}, {args.pixels}^2 px ({args.subpixels}^2 samples a pixel), {int(mask.sum())} pixels; "
          f"the path tracer's brightest one-bounce pixel {peak:.3f}")
    for name, image in images.items():
        print(f"{name:10s} mean {float(image[mask].mean()):.5f}  of the path tracer's "
              f"{float(image[mask].mean() / path[mask].mean()):.3f}  brightest pixel {float(image[mask].max()):.3f}  "
              f"share above the path tracer's brightest {100 * share_above(image, mask, peak):.0f} %")
    rows, cols = crop_box(path, mask, margin=args.pixels // 24)
    fig, axes = pyplot().subplots(len(images), 1, figsize=(6, 2.2 * len(images)), squeeze=False)
    for ax, (name, image) in zip(axes[:, 0], images.items(), strict=True):
        shown = ax.imshow(np.where(mask, image, np.nan)[rows, cols], vmin=0.0, vmax=peak, cmap="magma")
        ax.set_title(f"{name}: mean {float(image[mask].mean() / path[mask].mean()):.2f} of the path tracer's, "
                     f"{100 * share_above(image, mask, peak):.0f} % above its brightest pixel", fontsize=8)
        ax.set_axis_off()
        fig.colorbar(shown, ax=ax, fraction=0.03)
    fig.suptitle(f"{args.scene}: one bounce (linear radiance, clipped at the path tracer's brightest pixel)",
                 fontsize=9)
    save(fig, args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
