"""Regenerate tests/data/realtime_golden.npz: the real-time image of every builtin scene (and a few
paper-knob variants) at 48x48, as the paper's method rendered them before the techniques refactor.
tests/realtime/test_golden.py asserts today's renderer is bit-identical to them on
Mesa llvmpipe. Only rerun this when a change to the paper's own images is intended.

    .venv/bin/python tests/data/make_realtime_golden.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

SIZE = 48
#: (case name, scene, overrides on top of the small camera)
CASES = [(name, f"builtin:{name}", {}) for name in
         ("bowl-diffuse", "sphere-blend", "sphere-diffuse", "sphere-phong", "sphere-sky", "teapot-blend",
          "torus-phong")] + [
    ("sphere-phong-bias2", "builtin:sphere-phong", {"realtime.lod_bias": 2.0}),
    ("sphere-phong-bias-1.5-face16", "builtin:sphere-phong", {"realtime.lod_bias": -1.5, "realtime.face_size": 16}),
    ("sphere-blend-mcguire", "builtin:sphere-blend", {"realtime.lod_mapping": "mcguire"}),
    ("sphere-blend-auto-face", "builtin:sphere-blend",
     {"realtime.face_size": "auto", "camera.origin": [0.0, 0.0, 9.0]}),
    ("sphere-sky-auto-window", "builtin:sphere-sky", {"realtime.sh_window": "auto"}),
    ("sphere-diffuse-lanczos", "builtin:sphere-diffuse", {"realtime.sh_window": "lanczos", "realtime.face_size": 8}),
    ("sphere-blend-rotating", "builtin:sphere-blend", {"realtime.rotate_deg_per_frame": 7.0,
                                                       "environment.rotation_deg": 40.0}),
]


def small(overrides: dict) -> dict:
    return {"camera.width": SIZE, "camera.height": SIZE, "realtime.timing_frames": 1,
            "realtime.warmup_frames": 0, **overrides}


def main() -> None:
    import realtime
    import scenes

    out = {}
    for name, spec, ov in CASES:
        r = realtime.render(scenes.load(spec).with_overrides(small(ov)))
        out[f"{name}/rgb"] = r.rgb
        out[f"{name}/mask"] = r.mask
        print(name, float(r.rgb[r.mask].mean()) if r.mask.any() else None)
    np.savez_compressed(Path(__file__).with_name("realtime_golden.npz"), **out)


if __name__ == "__main__":
    main()
