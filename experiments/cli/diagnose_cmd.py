"""`iblcheck diagnose SCENE --image FILE [--json]`: which convention mistakes explain an engine's image.

Prints each accepted mistake with its fitted parameter and the dB its correction gains, and the PSNR of
the image against the reference before and after the corrections (experiments/measure/diagnosis/).
Exit 0 whatever is found (a diagnosis, not a gate); 2 for a bad scene or image.
"""

from __future__ import annotations

import argparse
import json

from experiments.cli.inputs import load_scene
from experiments.measure import diagnosis
from experiments.measure.diagnosis import hypotheses
from experiments.measure.diagnosis.renders import RENDERERS
from experiments.publish import outputs


def add_parser(sub) -> None:
    d = sub.add_parser("diagnose", help="which convention mistakes (flips, map rotation, fov axis, sRGB, exposure, "
                                        "half pixel, tone mapping) explain an engine's image",
                       description="Test the likely convention mistakes against the reference: "
                                   + "; ".join(f"{h.name}: {h.meaning}" for h in hypotheses.HYPOTHESES)
                                   + ". Reports those that explain the image with the dB each correction gains; "
                                     "exit 0 whatever is found.")
    d.add_argument("scene", help="scene file or builtin:NAME (builtin:calibration tells every mistake apart)")
    d.add_argument("--image", required=True, help="the engine's linear image of the scene (.exr, .pfm, .hdr)")
    d.add_argument("--reference", choices=RENDERERS, default="reference",
                   help="the path tracer (default; cached) or the noise-free quadrature (one convex object)")
    d.add_argument("--set", action="append", metavar="K=V", help="override a scene key (repeatable)")
    d.add_argument("--json", action="store_true", help="one JSON object instead of the table")


def run(args: argparse.Namespace) -> int:
    scene = load_scene(args.scene, args.set)
    image = diagnosis.read_image(args.image, scene)
    with outputs.progress("diagnose", 1) as step:
        step(f"{scene.name}: testing {len(hypotheses.NAMES)} mistakes")
        result = diagnosis.diagnose(scene, image, args.reference)
    print(json.dumps(result.to_dict(), allow_nan=False) if args.json else table(result))
    return 0


def table(d: diagnosis.Diagnosis) -> str:
    """The diagnosis in words: one line per accepted mistake, then the PSNR before and after."""
    lines = [f"{d.scene}: PSNR {d.psnr_before:.2f} dB against the {d.renderer} ({d.pixels} pixels)"
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
