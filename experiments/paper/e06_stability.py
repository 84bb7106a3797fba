"""E6 of the paper suite, stability: every hard case run once, with what happened.

Each case returns a row: its class, the case, what is expected, and the outcome observed (value
ranges, the error message, the SH window chosen). A case whose outcome breaks its expectation is
marked "UNEXPECTED" in the table; the same cases are asserted in tests/hard/. The hostile-input
classes (escaping, output paths, exit codes, silent misreads, back faces, stale sweeps) are run by
experiments/paper/e06_hostile_runs.py on the inputs of experiments/paper/e06_hostile_cases.py.
"""

from __future__ import annotations

import shutil
import tempfile
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import groundtruth
import realtime
import scenes
from experiments.measure import metrics
from experiments.measure.comparison import compare
from experiments.measure.pair import measure_pair
from experiments.paper.context import CommandLine, Context
from experiments.paper.e06_hostile_cases import error_of
from experiments.paper.e06_hostile_limits import LimitsAndTrustCases
from experiments.paper.e06_hostile_runs import HostileCases
from experiments.publish.report import Section, md_table, paragraph, table
from groundtruth.exact import quadrature
from scenes.environment import envmap
from scenes.storage import imageio

NUMBER = 6
TITLE = "E6 stability: hard cases"


@dataclass(frozen=True)
class Settings:
    spp: int  # reference samples per pixel of the cases that render one


QUICK = Settings(spp=64)
FULL = Settings(spp=256)

SMALL = {"camera.width": 48, "camera.height": 48, "realtime.timing_frames": 3, "realtime.warmup_frames": 1}


def _range(rgb: np.ndarray) -> str:
    return f"min {float(rgb.min()):.3g}, max {float(rgb.max()):.3g}, finite {bool(np.isfinite(rgb).all())}"


class Cases:
    def __init__(self, spp: int):
        self.spp = spp
        self.tmp = Path(tempfile.mkdtemp(prefix="iblcheck-e6-"))

    def scene(self, name: str, **ov):
        return scenes.load(name).with_overrides({**SMALL, "reference.spp": self.spp, **ov})

    def sun_windows(self) -> list[dict]:
        rows = []
        for sun in (1e3, 1e4, 1e6):
            base = self.scene("builtin:sphere-sky", **{"environment.params.sun": sun,
                                                        "objects.0.material": {"type": "diffuse"},
                                                        "camera.origin": [0.0, -1.5, 3.7]})
            ref = groundtruth.render(base)
            for window in ("none", "hanning", "lanczos", "auto"):
                r = realtime.render(base.with_overrides({"realtime.sh_window": window}))
                info = r.meta["sh_window"]
                psnr = measure_pair(r, ref, base).psnr
                vs_ref = "(no signal)" if psnr is None else f"{psnr:.2f} dB"
                cutoff = "-" if info["cutoff"] is None else f"{info['cutoff']:.3g}"
                ok = r.rgb.min() >= 0 and np.isfinite(r.rgb).all() and (
                    window != "auto" or info["min_irradiance_after"] >= 0)
                before, after = info["min_irradiance_before"], info["min_irradiance_after"]
                rows.append({"case": f"sun {sun:g} x sky, sh_window = {window}",
                             "expected": "E >= 0 after auto; shading never negative",
                             "outcome": (f"window {info['kind']} (cutoff {cutoff}); min E before {before:.3g}, "
                                         f"after {after:.3g}; PSNR vs reference {vs_ref}; image {_range(r.rgb)}"),
                             "ok": bool(ok)})
        return rows

    def exponents(self) -> list[dict]:
        rows = []
        for n in (0.0, 1.0, 1e4, 1e6):
            s = self.scene("builtin:sphere-phong", **{"objects.0.material.exponent": n,
                                                      "realtime.lod_mapping": "mcguire"})
            rt, ref, q = realtime.render(s), groundtruth.render(s), quadrature.render(s, subpixels=1)
            ok = all(np.isfinite(x.rgb).all() and x.rgb.min() >= 0 for x in (rt, ref, q))
            rows.append({"case": f"Phong exponent {n:g}", "expected": "finite in all three renderers",
                         "outcome": (f"real-time {_range(rt.rgb)}; reference {_range(ref.rgb)}; "
                                     f"quadrature {_range(q.rgb)}"),
                         "ok": bool(ok)})
        return rows

    def sizes(self) -> list[dict]:
        rows = []
        for label, ov in (("cube face 1", {"realtime.face_size": 1}), ("cube face 2", {"realtime.face_size": 2}),
                          ("cube face 4", {"realtime.face_size": 4}),
                          ("base 1024", {"realtime.base_size": 1024, "realtime.face_size": 1024}),
                          ("image 1 x 1", {"camera.width": 1, "camera.height": 1}),
                          ("image 4096 x 16", {"camera.width": 4096, "camera.height": 16})):
            r = realtime.render(self.scene("builtin:sphere-blend", **ov))
            rows.append({"case": label, "expected": "finite", "outcome": f"{_range(r.rgb)}; total "
                         f"{r.timings['total']:.1f} ms", "ok": bool(np.isfinite(r.rgb).all())})
        err = error_of(lambda: self.scene("builtin:sphere-blend", **{"realtime.base_size": 100}))
        rows.append({"case": "base_size 100", "expected": "refused: not a power of two", "outcome": err,
                     "ok": "power of two" in err})
        return rows

    def inputs(self) -> list[dict]:
        rows = []
        bad = np.ones((16, 32, 3), np.float32)
        bad[2, 3] = np.nan
        bad[5, 7, 2] = -4.0
        imageio.write_exr(self.tmp / "nan.exr", bad)
        err = error_of(lambda: envmap.read(self.tmp / "nan.exr"))
        rows.append({"case": "NaN and negative pixels", "expected": "refused, counted, named", "outcome": err,
                     "ok": "nan.exr" in err and "4 invalid" in err})
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            fixed = envmap.read(self.tmp / "nan.exr", sanitize=True)
        rows.append({"case": "the same with --sanitize", "expected": "repaired and counted",
                     "outcome": f"{'; '.join(str(w.message) for w in caught)}; map {_range(fixed)}",
                     "ok": bool(np.isfinite(fixed).all() and caught)})
        data = (self.tmp / "nan.exr").read_bytes()
        (self.tmp / "cut.exr").write_bytes(data[: len(data) // 2])
        err = error_of(lambda: envmap.read(self.tmp / "cut.exr"))
        rows.append({"case": "truncated EXR", "expected": "refused, named", "outcome": err, "ok": "cut.exr" in err})
        (self.tmp / "junk.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 8\n" + b"\x02\x02" * 3)
        err = error_of(lambda: envmap.read(self.tmp / "junk.hdr"))
        rows.append({"case": "corrupt HDR", "expected": "refused, named", "outcome": err, "ok": "junk.hdr" in err})
        for label, rgb in (("all-black map", np.zeros((16, 32, 3), np.float32)),
                           ("one 1e6 hot pixel", self._hot()),
                           ("1e6 everywhere (> half-float range)", np.full((16, 32, 3), 1e6, np.float32))):
            path = self.tmp / f"{label.split()[0]}.exr"
            imageio.write_exr(path, rgb)
            s = self.scene("builtin:sphere-diffuse", **{"environment.map": str(path)})
            r = realtime.render(s)
            same = metrics.psnr(metrics.display(s, r.rgb), metrics.display(s, r.rgb), r.mask)
            rows.append({"case": label, "expected": "finite; metrics defined",
                         "outcome": f"{_range(r.rgb)}; PSNR of the image with itself {same}",
                         "ok": bool(np.isfinite(r.rgb).all() and same is not None)})
        return rows

    @staticmethod
    def _hot() -> np.ndarray:
        rgb = np.full((32, 64, 3), 0.1, np.float32)
        rgb[10, 20] = 1e6
        return rgb

    def geometry(self) -> list[dict]:
        rows = []
        s = self.scene("builtin:sphere-blend", **{"camera.origin": [0.0, 0.0, 0.3], "objects.0.scale": 2.0})
        rt, ref = realtime.render(s), groundtruth.render(s)
        rows.append({"case": "camera inside the object", "expected": "finite",
                     "outcome": f"real-time {_range(rt.rgb)}; reference {_range(ref.rgb)}",
                     "ok": bool(np.isfinite(rt.rgb).all() and np.isfinite(ref.rgb).all())})
        s = self.scene("builtin:sphere-blend", **{"objects.0.translate": [30.0, 0.0, 0.0]})
        out = compare(realtime.render(s), groundtruth.render(s), s)
        rows.append({"case": "object outside the view", "expected": "empty mask, metrics null, a warning",
                     "outcome": f"pixels {out['pixels']}, PSNR {out['psnr']}", "ok": out["pixels"] == 0})
        err = error_of(lambda: self.scene("builtin:sphere-blend", **{"camera.up": [0.0, 0.0, 1.0]}))
        rows.append({"case": "up parallel to the view", "expected": "refused", "outcome": err,
                     "ok": "parallel" in err})
        return rows

    def determinism(self) -> list[dict]:
        s = self.scene("builtin:sphere-blend")
        a, b = groundtruth.render(s, use_cache=False), groundtruth.render(s, use_cache=False)
        c, d = realtime.render(s), realtime.render(s)
        same_rt = bool(np.array_equal(c.rgb, d.rgb))
        return [{"case": "reference twice, same seed", "expected": "bit-identical",
                 "outcome": f"identical: {bool(np.array_equal(a.rgb, b.rgb))} ({a.meta['variant']})",
                 "ok": bool(np.array_equal(a.rgb, b.rgb))},
                {"case": "real-time twice", "expected": "bit-identical",
                 "outcome": f"identical: {same_rt}", "ok": same_rt}]


#: the class of each of Cases' parts in the E6 table
CLASSES = {"sun_windows": "bright suns", "exponents": "exponents", "sizes": "sizes", "inputs": "environment maps",
           "geometry": "geometry", "determinism": "determinism"}


def parts(cases: Cases, hostile: HostileCases) -> list[tuple[str, Callable[[], list[dict]]]]:
    """(class, part) of every E6 case group, the hostile-input classes last."""
    own = [(CLASSES[name], getattr(cases, name)) for name in CLASSES]
    return own + [("", part) for part in hostile.parts()]


#: the hostile-input classes, in the order their parts run (e06_hostile_runs, then e06_hostile_limits)
HOSTILE_CLASSES = ("escaping", "output paths", "exit codes", "silent misreads", "back faces", "stale sweeps",
                   "machine limits", "tiny maps", "trusted files", "empty comparisons", "strict glTF", "Markdown",
                   "what ran", "smaller promises")


def count_parts() -> int:
    return len(CLASSES) + len(HOSTILE_CLASSES)


def count_steps(settings: Settings) -> int:
    """Progress steps of `run`: one per case group."""
    return count_parts()


def run_cases(spp: int, command_line: CommandLine, progress: Callable[[], None] | None = None) -> list[dict]:
    """Every case's row {"class", "case", "expected", "outcome", "ok"}, in the order of `parts`."""
    cases, hostile = Cases(spp), LimitsAndTrustCases(spp, command_line)
    rows = []
    try:
        for cls, part in parts(cases, hostile):
            rows += [{"class": cls, **r} for r in part()]
            if progress:
                progress()
    finally:
        for folder in (cases.tmp, hostile.tmp):
            shutil.rmtree(folder, ignore_errors=True)
    for r in rows:  # the temporary folders' names say nothing
        for folder in (cases.tmp, hostile.tmp):
            r["outcome"] = r["outcome"].replace(str(folder) + "/", "").replace(str(folder), ".")
    return rows


def run(context: Context, settings: Settings) -> Section:
    """E6's cases (run every time: they are not result rows) and its section. Needs the command line's
    entry points in `context.command_line` (the hostile cases run `iblcheck` commands)."""
    if context.command_line is None:
        raise ValueError("E6 runs iblcheck command lines: give the paper suite a CommandLine "
                         "(experiments/cli/main.py does)")
    return section(run_cases(settings.spp, context.command_line, context.progress))


def section(rows: list[dict]) -> Section:
    """E6's table of cases with what happened, and the count per class."""
    header = ["class", "case", "expected", "what happened"]
    cells = [[r.get("class", ""), r["case"], r["expected"], outcome_text(r)] for r in rows]
    bad = sum(not r["ok"] for r in rows)
    note = (f"{len(rows)} hard cases, {bad} unexpected ({counts(rows)}). The same cases are asserted in tests/hard/. "
            "Sun cases: a diffuse sphere under the sky seen from below the horizon; min E is SH9 irradiance over "
            "the sphere.")
    return Section(TITLE, [table(header, cells), paragraph(note)], md_table(header, cells) + "\n\n" + note)


def counts(rows: list[dict]) -> str:
    """'class: n cases (k unexpected)' for every class, in order."""
    out: dict[str, list[int]] = {}
    for r in rows:
        n = out.setdefault(r.get("class", ""), [0, 0])
        n[0] += 1
        n[1] += not r["ok"]
    return "; ".join(f"{c}: {n} cases" + (f" ({bad} unexpected)" if bad else "") for c, (n, bad) in out.items())


def outcome_text(row: dict) -> str:
    return row["outcome"] if row["ok"] else f"UNEXPECTED: {row['outcome']}"
