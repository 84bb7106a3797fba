"""`iblcheck compare SCENE --image FILE`: an engine's image scored against the scene's reference.

The encoding defaults from the suffix (EXR, PFM, HDR: linear radiance); a PNG or JPEG must name
`--image-encoding srgb` and its `--tonemap` (the operator the engine applied), since the same pixels mean
different radiance under each. Every bad image is exit 2 with one line naming the file.
"""

from __future__ import annotations

import argparse
import json

from experiments.cli.inputs import UsageError, load_scene
from experiments.measure import engine_image
from experiments.publish import outputs
from experiments.publish.text import comparison_table, one_line


def run(args: argparse.Namespace) -> int:
    scene = load_scene(args.scene, args.set, args.sanitize)
    path = args.image
    engine_image.check_file(path)
    encoding = args.image_encoding or engine_image.default_encoding(path)
    if encoding is None:
        raise UsageError(f"{path}: a PNG or JPEG holds tone-mapped sRGB: name --image-encoding srgb and the engine's "
                         f"--tonemap ({', '.join(engine_image.TONEMAPS)})")
    if encoding == "srgb" and args.tonemap is None:
        raise UsageError(f"{path}: --image-encoding srgb needs --tonemap NAME, the operator the engine applied")
    image = engine_image.read_engine_image(path, scene, encoding, args.tonemap or "none",
                                           1.0 if args.exposure is None else args.exposure)
    with outputs.progress("compare", 2) as step:
        step(f"{one_line(scene.name, 60)}: reference")
        result = engine_image.compare_image(image, scene).metrics
        step(f"{one_line(scene.name, 60)}: metrics")
    if args.json:
        print(json.dumps(result, allow_nan=False))
    else:
        print(comparison_table([result]))
        print(one_line(f"image: {result['image']} ({encoding}" + (f", {image.tonemap}, exposure {image.exposure:g}"
                                                                   if image.display_space else "") + ")", 300))
        if result.get("engine"):
            print(one_line(f"engine: {result['engine']} {result.get('engine_version') or ''}".rstrip()))
        if result.get("note"):
            print(one_line(result["note"]))
        if result.get("alpha"):
            print("the image's alpha channel is ignored (the reference's coverage decides which pixels count)")
    return 0
