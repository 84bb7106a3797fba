"""`iblcheck diagnose SCENE --image FILE [--image-encoding linear|srgb --tonemap NAME --exposure X] [--json]`.

Which convention mistakes explain an engine's image. Prints each accepted mistake with its fitted
parameter and the dB its correction gains, and the PSNR of the image against the reference before and
after the corrections (experiments/measure/diagnosis/). The image is read as `iblcheck compare --image`
reads it (experiments.measure.engine_image.read_engine_image): the encoding defaults from the suffix
(EXR, PFM, HDR: linear radiance); a PNG or JPEG is a tone-mapped sRGB image that must name
`--image-encoding srgb` and its `--tonemap` (and `--exposure`, default 1), and is diagnosed in its own
display space. Exit 0 whatever is found (a diagnosis, not a gate); 2 for a bad scene or image.
"""

from __future__ import annotations

import argparse
import json
import math
import warnings

from experiments.cli.inputs import UsageError, load_scene
from experiments.measure import diagnosis, engine_image
from experiments.measure.diagnosis import hypotheses
from experiments.measure.diagnosis.renders import RENDERERS
from experiments.publish import outputs
from groundtruth.exact import quadrature
from scenes.model import tone_operators


def add_parser(sub) -> None:
    d = sub.add_parser("diagnose", help="which convention mistakes (flips, map rotation, fov axis, sRGB, exposure, "
                                        "half pixel, tone mapping) explain an engine's image",
                       description="Test the likely convention mistakes against the reference: "
                                   + "; ".join(f"{h.name}: {h.meaning}" for h in hypotheses.HYPOTHESES)
                                   + ". Reports those that explain the image with the dB each correction gains; "
                                     "exit 0 whatever is found.")
    d.add_argument("scene", help="scene file or builtin:NAME (builtin:calibration tells every mistake apart)")
    d.add_argument("--image", required=True, help="the engine's image of the scene: linear radiance (.exr, .pfm, "
                   ".hdr) or a tone-mapped sRGB screenshot (.png, .jpg, .jpeg: name --image-encoding srgb and "
                   "--tonemap)")
    d.add_argument("--image-encoding", choices=list(engine_image.ENCODINGS),
                   help="linear radiance (EXR/PFM/HDR, the default for those) or tone-mapped sRGB (PNG/JPEG: must "
                        "be named, with --tonemap), as for `compare --image`")
    d.add_argument("--tonemap", choices=list(tone_operators.NAMES),
                   help="the operator the engine applied (srgb): the diagnosis predicts the image through it")
    d.add_argument("--exposure", type=_positive, help="the engine's exposure before its operator (srgb; default 1)")
    d.add_argument("--reference", choices=RENDERERS, default="reference",
                   help="the path tracer (default; cached) or the noise-free quadrature (one convex object)")
    d.add_argument("--set", action="append", metavar="K=V", help="override a scene key (repeatable)")
    d.add_argument("--json", action="store_true", help="one JSON object instead of the table")


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"--exposure {text!r}: expected a finite number > 0")
    return value


def run(args: argparse.Namespace) -> int:
    scene = load_scene(args.scene, args.set)
    path = args.image
    engine_image.check_file(path)
    encoding = args.image_encoding or engine_image.default_encoding(path)
    if encoding is None:
        raise UsageError(f"{path}: a PNG or JPEG holds tone-mapped sRGB: name --image-encoding srgb and the engine's "
                         f"--tonemap ({', '.join(tone_operators.NAMES)})")
    if encoding == "srgb" and args.tonemap is None:
        raise UsageError(f"{path}: --image-encoding srgb needs --tonemap NAME, the operator the engine applied")
    image = engine_image.read_engine_image(path, scene, encoding, args.tonemap or "none",
                                           1.0 if args.exposure is None else args.exposure)
    if args.reference == "quadrature" and (why := quadrature.inexact_for(scene)):
        warnings.warn(why, quadrature.NotTheReference, stacklevel=2)
    display = (diagnosis.Display(image.tonemap, image.exposure, image.bits) if image.display_space else None)
    with outputs.progress("diagnose", 1) as step:
        kind = hypotheses.DISPLAY if display else hypotheses.LINEAR
        step(f"{scene.name}: testing {len(hypotheses.FOR_IMAGE[kind])} mistakes")
        result = diagnosis.diagnose(scene, image.values.astype("float64"), args.reference, display)
    print(json.dumps(result.to_dict(), allow_nan=False) if args.json else table(result))
    return 0


def table(d: diagnosis.Diagnosis) -> str:
    """The diagnosis in words: one line per accepted mistake, then the PSNR before and after."""
    space = ("" if d.display is None else
             f" in display space ({d.display.tonemap}, exposure {d.display.exposure:g}, sRGB, code values)")
    lines = [f"{d.scene}: PSNR {d.psnr_before:.2f} dB against the {d.renderer}{space} ({d.pixels} pixels)"
             + (f", noise floor {d.noise_floor_psnr:.2f} dB" if d.noise_floor_psnr is not None else "")]
    if not d.mistakes:
        lines.append("no convention mistake explains the image (none gains 1 dB or more)")
    for s in d.mistakes:
        meaning = hypotheses.BY_NAME[s.name].meaning
        param = hypotheses.BY_NAME[s.name].parameter
        value = "" if s.parameter is None else (f" {param} = {s.parameter:.4g}" if isinstance(s.parameter, float)
                                                else f" {param} = {s.parameter}")
        lines.append(f"  {s.name}{value}: +{s.gain_db:.2f} dB (threshold {s.threshold_db:.2f}): {meaning}")
    if d.mistakes:
        lines.append(f"corrected: PSNR {d.psnr_after:.2f} dB")
    lines.append(f"({len(d.tested)} mistakes tested in {d.seconds:.1f} s)")
    return "\n".join(lines)
