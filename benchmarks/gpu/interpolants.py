"""What this GL's rasteriser hands the shading pass at each pixel: the interpolated normal and position, against the
ray cast's at the pixel's centre.

A triangle's attributes reach a fragment perspective-correct: the barycentric weights of the point where the
pixel centre's ray meets the triangle, which is what `groundtruth.exact.raycast.cast` computes in float64 (Moller-
Trumbore's u, v). So where both see the same triangle, the GL's normalised normal and its position should equal the
ray cast's to the GL's float precision. On the NVIDIA H200 eleven filtered-read tests missed their numpy mirrors by
2-5e-3 where llvmpipe met them, with the difference already present in front of any texture read (a constant sky
read along the mirror direction differed); this measures the interpolants themselves on each GL, so the two GLs'
figures say whether the rasteriser's sample point or interpolation is where they part.

    .venv/bin/python benchmarks/gpu/interpolants.py [--scene builtin:sphere-phong] [--size 64] [--out FILE.json]
    bash benchmarks/gpu/device.sh script benchmarks/gpu/interpolants.py --out $OUT/interpolants.json  # on a GPU

Prints, over the pixels both hit (and over those at least 2 px from any pixel either misses), the largest and
99th-percentile angle between the GL's normal and the ray cast's (radians), the same for the position (scene
units) and for the position's offset across the ray (which a sample point off the pixel centre shows), and the
pixels where the two disagree about coverage.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from scipy import ndimage

import realtime
import scenes
from groundtruth.exact import raycast
from realtime.engine import gpu
from realtime.engine.context import get_context
from scenes.storage import files

#: the shading pass's last line, which the measurement replaces with the interpolant it reads back
FINAL_LINE = "frag = vec4(max(color, vec3(0.0)), 1.0);"
#: the interpolants written in its place: the normal as the shading pass normalises it, and the position
OUTPUTS = {"normal": "frag = vec4(normalize(v_normal), 1.0);", "position": "frag = vec4(v_position, 1.0);"}


@contextlib.contextmanager
def shading_output(line: str) -> Iterator[None]:
    """The shading pass writes `line` in place of its radiance while inside."""
    original = gpu.shader_text

    def patched(name: str, package: str | None = None) -> str:
        text = original(name, package)
        if name == "shade.frag":
            if FINAL_LINE not in text:
                raise RuntimeError(f"shade.frag no longer ends with {FINAL_LINE!r}: update {__file__}")
            text = text.replace(FINAL_LINE, line)
        return text

    gpu.shader_text = patched
    try:
        yield
    finally:
        gpu.shader_text = original


def interpolants(scene) -> dict[str, np.ndarray]:
    """The GL's per-pixel normal and position (H, W, 3) and its coverage (H, W)."""
    out = {}
    for name, line in OUTPUTS.items():
        with shading_output(line):
            r = realtime.render(scene)
        out[name], out["mask"] = r.rgb.astype(np.float64), r.mask
    return out


def percentiles(values: np.ndarray) -> dict[str, float | None]:
    if values.size == 0:
        return {"max": None, "p99": None, "median": None}
    return {"max": float(values.max()), "p99": float(np.percentile(values, 99)), "median": float(np.median(values))}


def measure(spec: str, size: int) -> dict[str, object]:
    scene = scenes.load(spec).with_overrides({"camera.width": size, "camera.height": size,
                                              "realtime.timing_frames": 1, "realtime.warmup_frames": 0})
    gl = interpolants(scene)
    hits = raycast.cast(scene)
    ray_hit = hits.hit[..., 0]
    # the GL writes 0 for a one-sided back face (the silhouette's far side): no normal to compare there
    gl_hit = gl["mask"] & (np.linalg.norm(gl["normal"], axis=-1) > 0.5)
    both = gl_hit & ray_hit
    inner = ndimage.binary_erosion(both, iterations=2, border_value=0)
    n_ray, p_ray, d = hits.normal[..., 0, :], hits.position[..., 0, :], hits.direction[..., 0, :]
    n_gl = gl["normal"] / np.maximum(np.linalg.norm(gl["normal"], axis=-1, keepdims=True), 1e-30)
    angle = np.arccos(np.clip(np.sum(n_gl * n_ray, axis=-1), -1.0, 1.0))
    offset = gl["position"] - p_ray
    across = offset - np.sum(offset * d, axis=-1, keepdims=True) * d  # off the pixel centre's ray
    ctx = get_context()
    result: dict[str, object] = {"gl_renderer": ctx.info["GL_RENDERER"], "scene": spec, "size": size,
                                 "pixels_both": int(both.sum()), "pixels_inner": int(inner.sum()),
                                 "coverage_disagrees": int((gl_hit != ray_hit).sum())}
    for label, sel in (("all", both), ("inner", inner)):
        result[label] = {"normal_angle": percentiles(angle[sel]),
                         "position": percentiles(np.linalg.norm(offset, axis=-1)[sel]),
                         "position_across_ray": percentiles(np.linalg.norm(across, axis=-1)[sel])}
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="builtin:sphere-phong")
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--out", type=Path, help="also write the result here (JSON)")
    args = parser.parse_args(argv)
    text = json.dumps(measure(args.scene, args.size), indent=1) + "\n"
    sys.stdout.write(text)
    if args.out:  # written whole or not at all
        args.out.parent.mkdir(parents=True, exist_ok=True)
        files.write_bytes(args.out, text.encode())
    return 0


if __name__ == "__main__":
    sys.exit(main())
