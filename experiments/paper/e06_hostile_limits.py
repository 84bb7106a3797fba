"""E6's third round of hostile input: the machine's limits, tiny maps, files iblcheck trusts, empty
comparisons, strict glTF, Markdown, what ran, and the smaller promises. A few cases per class, each run
through the command line as a user would and judged by what the README promises; tests/hard/ holds the
many more cases each class has.
"""

from __future__ import annotations

import json
import re
import struct
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
from markdown_it import MarkdownIt

import realtime
import scenes
from experiments.paper.e06_hostile_runs import HostileCases, _row, error_line, tiny_scene
from experiments.publish import text
from groundtruth.pathtracer.variant import mitsuba
from scenes.environment import envmap

#: elements a rendered name must never produce in Markdown (links, images, emphasis, code)
LIVE_MARKDOWN = re.compile(r"<(a|img|em|strong|code|del|h\d|ul|ol|li|blockquote)\b", re.I)
MARKDOWN_NAMES = ("[click](http://evil.example/x)", "![pixel](http://evil.example/p.png)", "*em* **strong**",
                  "`code`", "<http://evil.example>", "# heading", "- item", "a | b")


class LimitsAndTrustCases(HostileCases):
    """The parts below, after HostileCases' own (escaping, output paths, exit codes, misreads, back
    faces, stale sweeps)."""

    def parts(self) -> list[Callable[[], list[dict]]]:
        return super().parts() + [self.machine_limits, self.tiny_maps, self.trusted_files, self.empty_comparisons,
                                  self.strict_gltf, self.markdown, self.what_ran, self.smaller_promises]

    def _random_map(self, name: str, shape: tuple[int, int]) -> Path:
        path = self.tmp / f"{name}.exr"
        envmap.write(path, np.random.default_rng(sum(shape)).uniform(0.2, 1.0, shape + (3,)).astype(np.float32))
        return path

    # ------------------------------------------------------------------------- machine limits
    def machine_limits(self) -> list[dict]:
        rows = []
        wide = tiny_scene(self.tmp, "wide", env=str(self._random_map("wide", (3, 16400))))
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            image = realtime.render(scenes.load(str(wide)))
        told = [str(w.message) for w in said if "downsampled" in str(w.message)]
        lit = float(image.rgb[image.mask].mean()) if image.mask.any() else 0.0
        rows.append(_row("machine limits", "a 3 x 16400 map (GL_MAX_TEXTURE_SIZE is 16384 on llvmpipe)",
                         "a downsampled map with one warning, never a black image",
                         f"{len(told)} warning(s); mean radiance {lit:.3f}", len(told) == 1 and lit > 0.05))
        code, _, err = self.cli("render", str(tiny_scene(self.tmp, "big-cube")), "--renderer", "realtime", "-o",
                                str(self.tmp / "big.exr"), "--set", "realtime.base_size=4096",
                                "--set", "realtime.face_size=8")
        line = err.strip().splitlines()[-1] if err.strip() else ""
        rows.append(_row("machine limits", "realtime.base_size = 4096 (a cube map llvmpipe cannot make)",
                         "exit 3 naming the key", f"exit {code}: {line[:140]}",
                         code == 3 and "base_size" in line and "Traceback" not in err))
        return rows

    # ------------------------------------------------------------------------- tiny maps
    def tiny_maps(self) -> list[dict]:
        rows = []
        two_rows = tiny_scene(self.tmp, "two-rows", env=str(self._random_map("two", (2, 8))))
        code, _, err = self.cli("render", str(two_rows), "--renderer", "realtime", "-o", str(self.tmp / "two-rows.exr"))
        ok, line = error_line(code, err)
        rows.append(_row("tiny maps", "a 2-row map (Mitsuba reads it otherwise)", "refused (exit 2), naming the rows",
                         line[:160], ok and "3 rows" in line))
        env = envmap.read(self._random_map("three", (3, 5)))
        d = np.array([[0.3, 0.9, -0.2], [-0.7, -0.1, 0.7], [0.0, -1.0, 0.0]])
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        mi = mitsuba()
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(-d[:, 0], -d[:, 1], -d[:, 2])
        seen = np.array(mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(env)}).eval(si))
        seen = seen.T if seen.shape[0] == 3 else seen
        gap = float(np.abs(seen - envmap.lookup(env, d)).max())
        rows.append(_row("tiny maps", "a 3 x 5 map read by Mitsuba and by the lookup both renderers use",
                         "the same radiance", f"largest difference {gap:.1e}", gap < 1e-5))
        return rows

    # ------------------------------------------------------------------------- trusted files
    def trusted_files(self) -> list[dict]:
        rows = []
        scene = tiny_scene(self.tmp, "trusted-baseline")
        record = self.tmp / "trusted-baseline.json"
        self.cli("gate", str(scene), "--min-psnr", "0", "--write-baseline", str(record))
        data = json.loads(record.read_text())
        entry = next(iter(data["scenes"].values()))
        entry["metrics"]["mse_se"] = -1.0
        record.write_text(json.dumps(data))
        code, _, err = self.cli("gate", str(scene), "--baseline", str(record))
        ok, line = error_line(code, err)
        rows.append(_row("trusted files", "a baseline with mse_se = -1 (it would widen the tolerance to 24 dB)",
                         "refused (exit 2) naming the file and the field", line[:160],
                         ok and "mse_se" in line and "baseline" in line))
        results = self.tmp / "trusted-rows" / "results.jsonl"
        results.parent.mkdir(exist_ok=True)
        self.cli("sweep", str(scene), "--face-sizes", "4", "--lod-biases", "0", "--out", str(results.parent))
        row = json.loads(results.read_text().splitlines()[0])
        row["ssim"] = 3.0
        results.write_text(json.dumps(row) + "\n")
        code, _, err = self.cli("report", str(results.parent))
        ok, line = error_line(code, err)
        rows.append(_row("trusted files", "a results.jsonl row with SSIM 3", "refused (exit 2) naming the field",
                         line[:160], ok and "ssim" in line))
        return rows

    # ------------------------------------------------------------------------- empty comparisons
    def empty_comparisons(self) -> list[dict]:
        rows = []
        inside = "--set", "camera.origin=[0.0, 0.0, 0.0]", "--set", "camera.target=[0.0, 0.0, -1.0]"
        scene = tiny_scene(self.tmp, "inside")
        code, out, err = self.cli("gate", str(scene), "--min-psnr", "20", *inside)
        rows.append(_row("empty comparisons", "the camera inside a one-sided sphere (both images black)",
                         "the gate fails it with the reason", f"exit {code}", code == 1 and "signal" in out + err))
        allowed = tiny_scene(self.tmp, "inside-allowed", extra="[gate]\nallow_empty = true\n")
        code, out, err = self.cli("gate", str(allowed), "--min-psnr", "20", *inside)
        rows.append(_row("empty comparisons", "the same with [gate] allow_empty = true", "passes (exit 0)",
                         f"exit {code}", code == 0))
        return rows

    # ------------------------------------------------------------------------- strict glTF
    def strict_gltf(self) -> list[dict]:
        rows = []
        tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()
        (self.tmp / "cube.bin").write_bytes(tri)
        base = {"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
                "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
                "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
                "bufferViews": [{"buffer": 0, "byteLength": 36}], "buffers": [{"byteLength": 36, "uri": "cube.bin"}]}
        cases = [("nodes 0 -> 1 -> 0 (a cycle)", {"nodes": [{"mesh": 0, "children": [1]}, {"children": [0]}]},
                  "ancestor"),
                 ("a buffer uri of http://127.0.0.1:9/cube.bin (a local cube.bin beside it)",
                  {"buffers": [{"byteLength": 36, "uri": "http://127.0.0.1:9/cube.bin"}]}, "network")]
        for label, change, says in cases:
            path = self.tmp / f"m{len(rows)}.gltf"
            path.write_text(json.dumps({**base, **change}))
            code, _, err = self.cli("render", str(tiny_scene(self.tmp, f"gltf{len(rows)}", shape=str(path))),
                                    "--renderer", "realtime", "-o", str(self.tmp / "g.exr"))
            ok, line = error_line(code, err)
            rows.append(_row("strict glTF", label, "refused (exit 2) with the rule it breaks", line[:160],
                             ok and says in line))
        glb = self.tmp / "long.glb"
        glb.write_bytes(b"glTF" + struct.pack("<II", 2, 10**9) + b"\0" * 8)
        code, _, err = self.cli("render", str(tiny_scene(self.tmp, "glb", shape=str(glb))), "--renderer", "realtime",
                                "-o", str(self.tmp / "g.exr"))
        ok, line = error_line(code, err)
        rows.append(_row("strict glTF", "a GLB whose header says 1e9 bytes", "refused (exit 2)", line[:160],
                         ok and "1000000000" in line))
        return rows

    # ------------------------------------------------------------------------- Markdown
    def markdown(self) -> list[dict]:
        md = MarkdownIt("commonmark")
        live = [name for name in MARKDOWN_NAMES if LIVE_MARKDOWN.search(md.render(text.md_cell(name)))]
        return [_row("Markdown", f"{len(MARKDOWN_NAMES)} names with links, images, emphasis, code, headings, "
                     "lists and pipes, rendered by a CommonMark renderer", "each renders as its text",
                     f"{len(live)} rendered as Markdown" + (f": {live}" if live else ""), not live)]

    # ------------------------------------------------------------------------- what ran
    def what_ran(self) -> list[dict]:
        scene = tiny_scene(self.tmp, "plane-vct", shape="plane", extra="")
        code, out, err = self.cli("render", str(scene), "--renderer", "realtime", "-o", str(self.tmp / "pv.exr"),
                                  "--set", "realtime.occlusion=vct", "--set", "camera.origin=[0.0, 2.0, 2.0]")
        said = [x for x in err.splitlines() if x.startswith("warning:") and "vct" in x]
        meta = json.loads(out.strip().splitlines()[-1]) if code == 0 and out.strip() else {}
        not_run = meta.get("techniques", {}).get("not_run", [])
        return [_row("what ran", 'realtime.occlusion = "vct" on one plane (nothing to shadow)',
                     "one warning, recorded as not run", f"exit {code}; {len(said)} warning(s); not_run {not_run}",
                     code == 0 and len(said) == 1 and "occlusion" in json.dumps(not_run))]

    # ------------------------------------------------------------------------- smaller promises
    def smaller_promises(self) -> list[dict]:
        rows = []
        bare = self.tmp / "no-objects.toml"
        bare.write_text('name = "bare"\n[environment]\nmap = "builtin:uffizi"\n')
        code, _, err = self.cli("render", str(bare), "--renderer", "realtime", "-o", str(self.tmp / "b.exr"))
        ok, line = error_line(code, err)
        rows.append(_row("smaller promises", "a scene file without [[objects]]", "refused (exit 2) naming the key",
                         line[:160], ok and "objects" in line))
        code, _, err = self.cli("render", str(tiny_scene(self.tmp, "slash")), "--renderer", "realtime", "-o",
                                str(self.tmp / "out2.exr") + "/")
        ok, line = error_line(code, err)
        rows.append(_row("smaller promises", "-o out2.exr/ (a trailing slash)", "refused like newout/ (exit 2)",
                         line[:160], ok and not (self.tmp / "out2.exr").exists()))
        return rows
