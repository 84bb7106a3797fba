"""E6's hostile-input cases, one part per class: escaping, output paths, exit codes, silent
misreads, back faces and silhouettes, stale sweeps. experiments/paper/e06_stability.py runs them after its own
cases; each returns rows {"class", "case", "expected", "outcome", "ok"} like the rest of E6.

The inputs come from experiments/paper/e06_hostile_cases.py, which tests/hard/ uses too (and asserts case by case).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import shutil
import tempfile
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import numpy as np

import groundtruth
import realtime
import scenes
from experiments.measure.pair import measure_pair
from experiments.measure.results import folder_lock
from experiments.paper import e06_hostile_cases as hostile
from experiments.paper.context import CommandLine
from experiments.paper.e06_hostile_cases import error_of
from experiments.publish import report
from experiments.publish.outputs import slug
from experiments.publish.text import comparison_table, visible
from experiments.runs import gate, sweep
from scenes.environment import envmap
from scenes.geometry import meshes
from scenes.storage import imageio


def _row(cls: str, case: str, expected: str, outcome: str, ok: bool) -> dict:
    return {"class": cls, "case": case, "expected": expected, "outcome": outcome, "ok": bool(ok)}


def run_cli(command_line: CommandLine, *args: str) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of `iblcheck ARGS` run in this process through `command_line`."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = command_line.main(list(args))
    return code, out.getvalue(), err.getvalue()


def error_line(code: int, err: str) -> tuple[bool, str]:
    """(one `error:` line and exit 2, the line)."""
    lines = [x for x in err.strip().splitlines() if not x.startswith("warning:")]
    line = lines[0] if lines else ""
    return code == 2 and len(lines) == 1 and line.startswith("error: ") and "Traceback" not in err, line


def tiny_scene(folder: Path, name: str = "tiny", env: str = "builtin:uffizi", shape: str = "sphere",
               extra: str = "") -> Path:
    path = Path(folder) / f"{hostile.file_safe(name)[:60] or 'scene'}.toml"
    path.write_text(f"name = {json.dumps(name)}\n[environment]\nmap = {json.dumps(env)}\n[camera]\n"
                    "origin = [0.0, 0.0, 4.0]\nfov_deg = 32.0\nwidth = 8\nheight = 8\n[[objects]]\n"
                    f'shape = {json.dumps(shape)}\nmaterial = {{ type = "blend" }}\n[realtime]\ntiming_frames = 1\n'
                    f"warmup_frames = 0\n[reference]\nspp = 4\n{extra}")
    return path


class HostileCases:
    """The hostile-input parts of E6. `command_line`: the `iblcheck` entry points (experiments/cli hands
    them down; this layer does not import the command line)."""

    def __init__(self, spp: int, command_line: CommandLine):
        self.spp = spp
        self.command_line = command_line
        # the working folder sits two levels inside a private one, so that what a case writes beside it (an
        # output path escaping upwards) is seen, and nothing another process puts in the system's temporary
        # folder is taken for it
        self.tmp = Path(tempfile.mkdtemp(prefix="iblcheck-e6h-")) / "outer" / "work"
        self.tmp.mkdir(parents=True)

    def cli(self, *args: str) -> tuple[int, str, str]:
        """(exit code, stdout, stderr) of `iblcheck ARGS`."""
        return run_cli(self.command_line, *args)

    def _beside_work(self) -> set[str]:
        """What the two private folders above the working folder hold, as 'folder/name'."""
        return {f"{level.name}/{name}" for level in (self.tmp.parent, self.tmp.parent.parent)
                for name in os.listdir(level)}

    # ------------------------------------------------------------------------- 1 escaping
    def escaping(self) -> list[dict]:
        n = len(hostile.HOSTILE_NAMES)
        rows = hostile.hostile_rows()
        index = report.build(self.tmp / "report", title=hostile.HOSTILE_NAMES[0], rows=rows,
                             sections=[report.Section(hostile.HOSTILE_NAMES[1], [report.table(["x"], [[x] for x in
                                       hostile.HOSTILE_NAMES]), report.paragraph(hostile.HOSTILE_NAMES[2])],
                                       report.md_table(["x"], [[x] for x in hostile.HOSTILE_NAMES]))])
        page = hostile.page_problems(index.read_text())
        md = hostile.markdown_problems((self.tmp / "report" / "summary.md").read_text())
        results = [gate.GateResult(x, {"psnr": 1.0}, {"min_psnr": 2.0}, ["psnr low"]) for x in hostile.HOSTILE_NAMES]
        gate.write_junit(self.tmp / "gate.xml", results)
        try:
            names = [c.get("name") for c in ET.parse(self.tmp / "gate.xml").getroot().iter("testcase")]
            junit = f"parses, {len(names)} test cases"
        except ET.ParseError as exc:
            names, junit = [], f"does not parse ({exc})"
        term = hostile.terminal_problems(gate.format_table(results) + comparison_table([{"scene": x}
                                                                                  for x in hostile.HOSTILE_NAMES]))
        return [
            _row("escaping", f"{n} hostile names in scene, map and technique fields, section tables and the title "
                 "of an HTML report", "no element, attribute, script or network source they bring; CSP set",
                 "; ".join(page) or "all shown as text", not page),
            _row("escaping", f"the same {n} names in summary.md", "no raw HTML, no broken table rows",
                 "; ".join(md) or "escaped", not md),
            _row("escaping", f"the same {n} names (control characters included) in JUnit XML", "parses",
                 junit, len(names) == n),
            _row("escaping", f"the same {n} names in the gate and compare tables (terminal)",
                 "no control characters", "; ".join(term) or "none", not term),
            *self._escaping_cli(),
        ]

    def _escaping_cli(self) -> list[dict]:
        names = [x for x in hostile.HOSTILE_NAMES]
        bad = []
        for x in names:
            code, _, err = self.cli("render", str(self.tmp / f"{hostile.file_safe(x)}.toml"), "--set", f"name={x}")
            ok, line = error_line(code, err)
            if not ok or hostile.terminal_problems(line):
                bad.append(visible(x))
        return [_row("escaping", f"{len(names)} hostile file names and --set values in error lines",
                     "one line, exit 2, no control characters", "; ".join(bad) or "all escaped", not bad)]

    # ------------------------------------------------------------------------- 2 output paths
    def output_paths(self) -> list[dict]:
        rows = []
        scene = tiny_scene(self.tmp, "../../escape")
        before = self._beside_work()
        with contextlib.chdir(self.tmp):
            code, out, err = self.cli("render", str(scene))
        written = sorted(p.name for p in self.tmp.glob("*-realtime.*"))
        leaked = self._beside_work() - before
        rows.append(_row("output paths", 'render without -o, name = "../../escape"',
                         "written as escape-realtime.exr/.png in the working directory",
                         f"exit {code}; wrote {', '.join(written)}; outside: {sorted(leaked) or 'nothing'}",
                         code == 0 and written == ["escape-realtime.exr", "escape-realtime.png"] and not leaked))
        names = ["/etc/passwd", "..", "", "\x1b[2J", "a" * 300, "CON.exr"]
        slugs = [slug(x) for x in names]
        rows.append(_row("output paths", f"{len(names)} more names as default output names (absolute, '..', "
                         "empty, escapes, 300 characters)", "file-safe stems of at most 64 characters",
                         ", ".join(s[:20] for s in slugs),
                         all(s and "/" not in s and not s.startswith(".") and len(s) <= 64 for s in slugs)))
        for label, args in self._bad_outputs(scene):
            leftovers_before = self._leftovers()
            code, _, err = self.cli(*args)
            ok, line = error_line(code, err)
            extra = self._leftovers() - leftovers_before
            rows.append(_row("output paths", label, "exit 2 before anything renders, one error line, no file left",
                             f"{line[:160]}" + (f"; left {sorted(extra)}" if extra else ""), ok and not extra))
        return rows

    def _bad_outputs(self, scene: Path) -> list[tuple[str, list[str]]]:
        f = self.tmp
        (f / "a-file").write_text("x")
        (f / "a-folder.exr").mkdir(exist_ok=True)
        (f / "out.png").mkdir(exist_ok=True)
        if not (f / "pipe.exr").exists():
            os.mkfifo(f / "pipe.exr")
        imageio.write_exr(f / "own.exr", np.full((8, 16, 3), 0.5, np.float32))
        return [("-o inside a file (a-file/out.exr)", ["render", str(scene), "-o", str(f / "a-file/out.exr")]),
                ("-o a folder", ["render", str(scene), "-o", str(f / "a-folder.exr")]),
                ("-o whose .png is a folder", ["render", str(scene), "-o", str(f / "out.exr")]),
                ("-o a named pipe", ["render", str(scene), "-o", str(f / "pipe.exr")]),
                ("-o in /proc", ["render", str(scene), "-o", "/proc/iblcheck-e6/out.exr"]),
                ("-o in read-only /sys", ["render", str(scene), "-o", "/sys/iblcheck-e6.exr"]),
                ("-o onto the scene file's own map", ["render", str(tiny_scene(f, "own", env="own.exr")),
                                                     "-o", str(f / "own.exr")]),
                ("--junit a folder", ["gate", str(scene), "--min-psnr", "1", "--junit", str(f / "a-folder.exr")]),
                ("--junit in /proc", ["gate", str(scene), "--min-psnr", "1", "--junit", "/proc/x/gate.xml"]),
                ("sweep --out a file", ["sweep", str(scene), "--out", str(f / "a-file")]),
                ("sweep --out in /proc", ["sweep", str(scene), "--out", "/proc/iblcheck-e6"]),
                ("paper --out a file", ["paper", "--quick", "--out", str(f / "a-file")]),
                ("report of a file", ["report", str(f / "a-file")])]

    def _leftovers(self) -> set[str]:
        return {str(p) for p in self.tmp.rglob("*") if ".tmp" in p.name or p.name.startswith(".iblcheck-probe")}

    # ------------------------------------------------------------------------- 3 exit codes
    def exit_codes(self) -> list[dict]:
        rows = []
        for label, exc, want in (("an internal error (ZeroDivisionError)", ZeroDivisionError("division by zero"), 4),
                                 ("an internal error (AttributeError)", AttributeError("x"), 4),
                                 ("Ctrl-C (KeyboardInterrupt)", KeyboardInterrupt(), 130),
                                 ("out of memory", MemoryError(), 3)):
            def boom(args, exc=exc):
                raise exc

            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                code = self.command_line.run_command(argparse.Namespace(func=boom))
            lines = err.getvalue().strip().splitlines()
            rows.append(_row("exit codes", label, f"exit {want}, one error line, no traceback",
                             f"exit {code}: {lines[0][:120] if lines else ''}",
                             code == want and len(lines) == 1 and "Traceback" not in err.getvalue()))
        for label, args in self._crashers():
            code, _, err = self.cli(*args)
            ok, line = error_line(code, err)
            rows.append(_row("exit codes", label, "exit 2, one error line", f"exit {code}: {line[:160]}", ok))
        rows += self._finite_extremes()
        return rows

    def _crashers(self) -> list[tuple[str, list[str]]]:
        f = self.tmp
        (f / "special").mkdir(exist_ok=True)
        loop_map = hostile.special_paths(f / "special")[0][1]
        loop_mesh = hostile.special_paths(f / "special", ".obj")[0][1]
        (f / "latin1.toml").write_bytes('name = "caf\xe9"\n'.encode("latin-1"))
        (f / "deep.toml").write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
        (f / "deep50.toml").write_text("name = 'd'\n[camera]\norigin = " + "[" * 50 + "]" * 50 + "\n")
        big = np.full((8, 16, 3), 0.5, np.float32)
        big[2, 3] = 3e38
        imageio.write_exr(f / "huge.exr", big)
        bad_rows = f / "rows"
        bad_rows.mkdir(exist_ok=True)
        (bad_rows / "results.jsonl").write_text('{"id": "x", "spec": 5}\n[1, 2]\n')
        scene = tiny_scene(f, "ok")
        return [("a symbolic link loop as the map", ["render", str(tiny_scene(f, "l", env=str(loop_map)))]),
                ("a symbolic link loop as the mesh", ["render", str(scene), "--set", f"objects.0.shape={loop_mesh}"]),
                ("a scene file that is not UTF-8", ["render", str(f / "latin1.toml")]),
                ("a TOML file nesting arrays 5000 deep", ["render", str(f / "deep.toml")]),
                ("a TOML file nesting arrays 50 deep", ["render", str(f / "deep50.toml")]),
                ("a --set value nesting 5000 deep", ["render", str(scene), "--set",
                                                    "camera.origin=" + "[" * 5000 + "]" * 5000]),
                ("a complete but corrupt line in results.jsonl", ["report", str(bad_rows)]),
                ("a map value of 3e38 (float32 maximum)", ["render", str(tiny_scene(f, "h", env=str(f / "huge.exr")))]),
                ("a vanishing field of view (1e-30 degrees)", ["render", str(scene), "--set", "camera.fov_deg=1e-30"]),
                ("16384 x 16384 pixels", ["render", str(scene), "--set", "camera.width=16384", "--set",
                                          "camera.height=16384"]),
                ("a builtin sphere at resolution 1024 (4 M triangles)", ["render", str(scene), "--set",
                                                                         "objects.0.resolution=1024"]),
                ("--min-psnr nan", ["gate", str(scene), "--min-psnr", "nan"]),
                ("--min-psnr inf", ["gate", str(scene), "--min-psnr", "inf"]),
                ("--min-ssim 2", ["gate", str(scene), "--min-ssim", "2"]),
                ("--max-flip -0.5", ["gate", str(scene), "--max-flip=-0.5"])]

    def _finite_extremes(self) -> list[dict]:
        rows = []
        for value in (1e19, 1e20):
            rgb = np.full((8, 16, 3), 0.5, np.float32)
            rgb[2, 3] = value
            imageio.write_exr(self.tmp / "bright.exr", rgb)
            s = scenes.load(tiny_scene(self.tmp, "bright", env=str(self.tmp / "bright.exr")))
            r = realtime.render(s)
            rows.append(_row("exit codes", f"a map value of {value:g} (the largest accepted is 1e20)",
                             "a finite render", f"finite {bool(np.isfinite(r.rgb).all())}, max {r.rgb.max():.3g}",
                             np.isfinite(r.rgb).all()))
        return rows

    # ------------------------------------------------------------------------- 4 silent misreads
    def misreads(self) -> list[dict]:
        rows = []
        folder = self.tmp / "maps"
        folder.mkdir(exist_ok=True)
        for label, path, word in hostile.misread_maps(folder):
            err = error_of(lambda p=path: envmap.read(p))
            rows.append(_row("silent misreads", label, f"refused, naming what it holds ({word})", err[:200],
                             word in err and path.name in err and not hostile.python_text(err)))
        special = self.tmp / "special"
        special.mkdir(exist_ok=True)
        for label, path, word in hostile.special_paths(special):
            err = error_of(lambda p=path: envmap.read(p))
            rows.append(_row("silent misreads", f"{label} given as a map", f"says so ({word})", err[:200], word in err))
        rows += self._mesh_fuzz()
        rows += self._long_values()
        return rows

    def _mesh_fuzz(self) -> list[dict]:
        folder = self.tmp / "meshes"
        folder.mkdir(exist_ok=True)
        cases = hostile.mesh_cases()
        outcomes: dict[str, list[str]] = {}
        with warnings.catch_warnings():  # repaired meshes (flipped normals) say so; not this case's subject
            warnings.simplefilter("ignore")
            for i, (label, kind, data) in enumerate(cases):
                path = folder / f"m{i}.{kind}"
                path.write_bytes(data)
                outcomes.setdefault(hostile.mesh_outcome(path), []).append(label)
        bad = {k: v for k, v in outcomes.items() if k not in ("refused", "loaded")}
        return [_row("silent misreads", f"{len(cases)} broken or truncated OBJ and PLY files",
                     "refused with the file (and line) named, never Python's own text",
                     f"{len(outcomes.get('refused', []))} refused, {len(outcomes.get('loaded', []))} loaded (a cut "
                     f"that leaves a valid mesh); otherwise: {bad or 'none'}", not bad)]

    def _long_values(self) -> list[dict]:
        scene = tiny_scene(self.tmp, "long")
        code, _, err = self.cli("render", str(scene), "--set", "objects.0.material.kd=[" + "0.5," * 1_000_000 + "0.5]")
        ok, line = error_line(code, err)
        rows = [_row("silent misreads", "a kd of a million numbers", "one line of sensible length naming the key",
                     f"{len(line)} characters: {line[-90:]}", ok and len(line) < 1000 and "material.kd" in line)]
        limit = meshes.MAX_TRIANGLES
        path = self.tmp / "many.obj"
        path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n" + "f 1 2 3\n" * 101)
        try:
            meshes.MAX_TRIANGLES = 100
            err = error_of(lambda: meshes.load_file(path))
        finally:
            meshes.MAX_TRIANGLES = limit
        rows.append(_row("silent misreads", f"a mesh over the face limit (the limit is {limit}; 100 for this case)",
                         "refused before parsing, with the number", err[:160], "101 triangles" in err))
        return rows

    # ------------------------------------------------------------------------- 5 back faces
    def back_faces(self) -> list[dict]:
        rows = []
        plane = {"objects.0.shape": "plane", "camera.origin": [0.0, -2.5, 2.5]}
        for label, ov in (("plane seen from below, one-sided", plane),
                          ("plane seen from below, two-sided", {**plane, "objects.0.material.two_sided": True}),
                          ("plane seen from above", {**plane, "camera.origin": [0.0, 2.5, 2.5]})):
            rows.append(self._compare_row(label, ov))
        for shared in (True, False):
            path = self.tmp / f"cube-{'shared' if shared else 'faces'}.obj"
            path.write_text(hostile.cube_obj(shared))
            ov = {"objects.0.shape": str(path), "objects.0.rotate_deg": [30.0, 40.0, 0.0], "objects.0.scale": 1.3}
            kind = "shared vertices (smooth normals)" if shared else "per-face normals"
            rows.append(self._compare_row(f"cube, {kind}", ov))
        rows.append(self._compare_row("sphere of 4 x 8 quads: its rim", {"objects.0.resolution": 4}))
        rows.append(self._inside_row())
        return rows

    def _compare_row(self, label: str, ov: dict) -> dict:
        s = scenes.load("builtin:sphere-blend").with_overrides({**self._small(), **ov})
        rt, ref = realtime.render(s), groundtruth.render(s)
        m = measure_pair(rt, ref, s)
        black = int(((rt.rgb == 0).all(-1) & rt.mask).sum())
        if m.empty:  # no signal to score: the rule holds when both images are black where they are covered
            shown, ok = f"both black ({m.empty})", not rt.rgb[m.mask].any() and not ref.rgb[m.mask].any()
        else:
            shown, ok = f"PSNR {m.psnr:.2f} dB", m.psnr is not None and m.psnr > 15
        return _row("back faces", label, "both renderers apply one rule: black where n.v <= 0 unless two-sided",
                    f"{shown}; {black} of {int(rt.mask.sum())} real-time pixels black", ok)

    def _inside_row(self) -> dict:
        s = scenes.load("builtin:sphere-blend").with_overrides({**self._small(), "camera.origin": [0.0, 0.0, 0.3],
                                                                "objects.0.scale": 2.0})
        one, two = realtime.render(s), realtime.render(s.with_overrides({"objects.0.material.two_sided": True}))
        return _row("back faces", "camera inside a sphere: one-sided, then two-sided",
                    "black (every pixel sees the back), then lit",
                    f"max {one.rgb.max():.3g}, then min {two.rgb.min():.3g}", one.rgb.max() == 0 and two.rgb.min() > 0)

    def _small(self) -> dict:
        return {"camera.width": 32, "camera.height": 32, "reference.spp": self.spp, "realtime.timing_frames": 1,
                "realtime.warmup_frames": 0}

    # ------------------------------------------------------------------------- 6 stale sweeps
    def stale_sweeps(self) -> list[dict]:
        rows = []
        scene = tiny_scene(self.tmp, "stale", env=str(self._map()), shape=str(self._mesh()))
        spec = str(scene)
        before = sweep.row_id(spec, {})
        edits = (("kd in the scene file", lambda: scene.write_text(scene.read_text().replace(
                    '{ type = "blend" }', '{ type = "blend", kd = [0.5, 0.5, 0.5] }'))),
                 ("the map's bytes (same path)", lambda: self._map(0.7)),
                 ("the mesh's bytes (same path)", lambda: self._mesh(1.1)))
        for label, edit in edits:
            edit()
            after = sweep.row_id(spec, {})
            rows.append(_row("stale sweeps", f"edit {label}", "a new row id (the old row is stale)",
                             f"{before} -> {after}", after != before))
            before = after
        axes = [("--face-sizes 8,8", sweep.Axes(face_sizes=[8, 8], lod_biases=None)),
                ("--axis realtime.face_size=8,8.0", sweep.Axes(face_sizes=None, lod_biases=None,
                                                                extra=[("realtime.face_size", [8, 8.0])])),
                ("--envs a.exr,./a.exr,copy-of-a.exr", sweep.Axes(face_sizes=None, lod_biases=None,
                                                                  envs=self._map_copies()))]
        for label, ax in axes:
            n = len(sweep.plan([spec, spec], ax))
            rows.append(_row("stale sweeps", f"{label}, the scene given twice", "one row", f"{n} rows", n == 1))
        rows.append(self._lock_row(scene))
        return rows

    def _map(self, value: float = 0.5) -> Path:
        imageio.write_exr(self.tmp / "a.exr", np.full((8, 16, 3), value, np.float32))
        return self.tmp / "a.exr"

    def _map_copies(self) -> list[str]:
        shutil.copy(self.tmp / "a.exr", self.tmp / "copy-of-a.exr")
        return [str(self.tmp / "a.exr"), os.path.join(str(self.tmp), ".", "a.exr"), str(self.tmp / "copy-of-a.exr")]

    def _mesh(self, scale: float = 1.0) -> Path:
        path = self.tmp / "m.obj"
        path.write_text(hostile.cube_obj(False, 0.5 * scale))
        return path

    def _lock_row(self, scene: Path) -> dict:
        out = self.tmp / "locked"
        out.mkdir(exist_ok=True)
        with folder_lock(out):
            code, _, err = self.cli("sweep", str(scene), "--face-sizes", "8", "--lod-biases", "0", "--out", str(out))
        ok, line = error_line(code, err)
        return _row("stale sweeps", "a second sweep into a folder being written", "refused (exit 2)",
                    line[:160], ok and "another iblcheck" in line)

    def parts(self) -> list[Callable[[], list[dict]]]:
        return [self.escaping, self.output_paths, self.exit_codes, self.misreads, self.back_faces, self.stale_sweeps]
