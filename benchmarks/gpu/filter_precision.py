"""How finely this GL's texture unit resolves its filter weights: the bilinear fraction and the trilinear LOD fraction.

A float texture read with `texture()` between two texels holding 0 and 1 returns the bilinear weight itself, and
`textureLod()` between a mip level of 0 and one of 1 returns the LOD's fraction. Swept over N evenly spaced
positions, exact float filtering (Mesa llvmpipe) returns N distinct values on the line y = t; a texture unit that
quantises its weights to b bits returns 2^b + 1 steps and misses the line by up to 2^-(b+1) where it rounds and
2^-b where it truncates. The OpenGL
specification leaves this precision to the implementation (D3D11 requires at least 8 bits of sub-texel precision
for the bilinear weight): a filtered read on hardware may miss its exact float mirror by the weight step times
the difference between the texels (or levels) it blends.

    .venv/bin/python benchmarks/gpu/filter_precision.py [--out FILE.json]          # here (llvmpipe)
    bash benchmarks/gpu/device.sh script benchmarks/gpu/filter_precision.py --out $OUT/filter.json   # on a GPU
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import moderngl
import numpy as np

from realtime.engine.context import get_context

N = 4096

VERTEX = """#version 430
in vec2 position;
void main() { gl_Position = vec4(position, 0.0, 1.0); }
"""

#: the fragment shader: pixel x of N reads the texture at t = x / (N - 1) through READ, and writes (value, t)
FRAGMENT = """#version 430
uniform sampler2D tex;
uniform float n;
out vec4 colour;
void main() {
    float t = (gl_FragCoord.x - 0.5) / (n - 1.0);
    colour = vec4(READ, t, 0.0, 1.0);
}
"""
#: the bilinear weight: u runs from texel 0's centre (0.25 of a 2-texel row) to texel 1's (0.75)
BILINEAR = "texture(tex, vec2(0.25 + 0.5 * t, 0.5)).r"
#: the LOD fraction: level 0 holds 0, level 1 holds 1, read at LOD t
TRILINEAR = "textureLod(tex, vec2(0.5), t).r"


def sweep(ctx: moderngl.Context, read: str, texture: moderngl.Texture) -> dict[str, float | int | None]:
    """Reads the filtered value at N positions t in [0, 1] through `read` and sets it against t (`weight_steps`)."""
    program = ctx.program(vertex_shader=VERTEX, fragment_shader=FRAGMENT.replace("READ", read))
    program["n"].value = float(N)
    quad = ctx.buffer(np.array([-1, -1, 1, -1, -1, 1, 1, 1], np.float32).tobytes())
    vao = ctx.vertex_array(program, [(quad, "2f", "position")])
    target = ctx.texture((N, 1), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[target])
    fbo.use()
    ctx.viewport = (0, 0, N, 1)
    texture.use(0)
    program["tex"].value = 0
    vao.render(moderngl.TRIANGLE_STRIP)
    rgba = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32).reshape(N, 4).astype(np.float64)
    for obj in (fbo, target, vao, quad, program):
        obj.release()
    return weight_steps(rgba[:, 0], rgba[:, 1])


def weight_steps(value: np.ndarray, t: np.ndarray) -> dict[str, float | int | None]:
    """The filtered values against the exact weights t: the largest miss, the number of distinct values and the
    bits they resolve, None where every value differs (the weights are finer than the sweep can tell)."""
    steps = len(np.unique(value))
    quantised = steps < len(t)
    return {"max_abs_error": float(np.abs(value - t).max()), "distinct_values": steps,
            "weight_bits": round(math.log2(max(steps - 1, 1)), 2) if quantised else None}


def measure() -> dict[str, object]:
    ctx = get_context()
    two_texels = ctx.texture((2, 1), 1, np.array([0.0, 1.0], np.float32).tobytes(), dtype="f4")
    two_texels.filter = (moderngl.LINEAR, moderngl.LINEAR)
    two_texels.repeat_x = two_texels.repeat_y = False
    levels = ctx.texture((2, 2), 1, np.zeros(4, np.float32).tobytes(), dtype="f4")
    levels.build_mipmaps(0, 1)  # allocates level 1, then overwritten with 1
    levels.write(np.ones(1, np.float32).tobytes(), level=1)
    levels.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    out = {"gl_renderer": ctx.info["GL_RENDERER"], "gl_version": ctx.info["GL_VERSION"], "positions": N,
           "bilinear": sweep(ctx, BILINEAR, two_texels), "trilinear_lod": sweep(ctx, TRILINEAR, levels)}
    two_texels.release()
    levels.release()
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="also write the result here (JSON)")
    args = parser.parse_args(argv)
    result = measure()
    text = json.dumps(result, indent=1)
    print(text)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
