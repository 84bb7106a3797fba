"""E10's real-time rows timed on whatever GL this machine has, and two such runs compared.

    python benchmarks/gpu/e10_frames.py measure --out DIR [--frames 20] [--warmup 3] [--size 1920x1080]
                                                [--scene bowl-diffuse]
    python benchmarks/gpu/e10_frames.py compare GPU_DIR CPU_DIR [--markdown FILE] [--figure FIG.png]
    python benchmarks/gpu/e10_frames.py ladder GPU_DIR --summary reports/paper/summary.md --out FIG.png

`measure` renders every real-time row of E10 (experiments/paper/e10_voxel_cone_tracing.py, its FULL
settings: the paper's direct light, VCT's occlusion with and without interreflection over its resolution x
cascades x cones grid, PRT with a bounce, the light array with shadow maps) on cornell-open, bowl-diffuse and
torus-phong, at E10's image size (192 x 192) and at each `--size`. Per row it keeps the frame's timings
(medians over `--frames` frames after `--warmup`, realtime/engine/frame.py) in DIR/frames.json and the
192 x 192 images in DIR/images.npz, both rewritten after every row (each file replaced whole) so that a run
stopped at its time limit keeps what it finished; frames.json also holds the context's GL_MAX_* limits. The
images are float16 linear RGB, clamped at float16's largest value, with the coverage mask; a row records how
many of its values were not finite or clamped. Nothing here needs Mitsuba: the accuracy of each row is E10's,
measured against the path tracer on llvmpipe (reports/paper/summary.md).

`compare` sets a GPU run beside an llvmpipe run of the same rows: each row's frame time on both, their
ratio, and the GPU image against llvmpipe's: PSNR of the displayed images over the pixels both cover, eroded
by one pixel as every iblcheck metric's mask is (metrics.common_mask), and the pixels only one covers. The two
GLs run the same shaders on the same inputs, so the images must agree to within float rounding and filtering:
an axis flip, a face swap or a missing pass shows as a PSNR near the images' own contrast, not 40 dB and more.
`--figure` draws, per scene, the row whose images differ most: both images as displayed and where they differ
(over the pixels either covers).

`ladder` draws E10's accuracy-time ladder with the GPU's milliseconds: per scene, each row's unbiased PSNR
against the path tracer at 192 x 192 (E10's, read from its table in the paper summary; valid for the GPU's image
where `compare` finds it the same as llvmpipe's) against its GPU frame time at 192 x 192 and at the larger
size. A PSNR E10 marks "(floor)", only a lower bound, is drawn as a triangle pointing up.

Bad input (an unknown scene, a folder without frames.json, a summary without E10's table, fewer than one
timed frame) ends with one line naming it and exit status 2.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import realtime
import scenes
from experiments.measure import metrics
from experiments.paper import context
from experiments.paper import e10_voxel_cone_tracing as e10
from experiments.publish import plots
from experiments.publish.images import to_float16
from realtime.engine.context import get_context, is_software, renderer_name
from realtime.engine.frame import TechniqueNotRunWarning
from realtime.engine.technique import UnsimulatedEffectWarning
from scenes.storage.files import atomic_output, write_bytes

ROOT = Path(__file__).resolve().parents[2]
#: PSNR of the GPU's displayed image against llvmpipe's under which a row is flagged as disagreeing: float
#: rounding and the two GLs' texture filtering leave differences far below it, a convention error far above
AGREE_DB = 40.0
#: E10's image size (its rows' PSNR are measured at it): every row is timed at it, and its images kept
E10_SIZE = (context.FULL.size, context.FULL.size)


class FramesInputError(ValueError):
    """A bad argument or input file; main turns it into one line and exit status 2."""


def row_key(scene: str, overrides: dict, size: tuple[int, int]) -> str:
    """One row's name, the same on every machine: scene, its overrides sorted, and the image size."""
    parts = [scene] + [f"{k.removeprefix('realtime.')}={v}" for k, v in sorted(overrides.items())]
    return " ".join([*parts, f"{size[0]}x{size[1]}"])


def parse_size(text: str) -> tuple[int, int]:
    """WIDTHxHEIGHT as (width, height), both positive (argparse's type for --size)."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size {text!r}: expected WIDTHxHEIGHT, e.g. 1920x1080") from None
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"--size {text!r}: width and height must be positive")
    return w, h


def rows(sizes: list[tuple[int, int]], only: list[str] | None = None
         ) -> list[tuple[str, str, dict, tuple[int, int]]]:
    """(scene name, scene spec, overrides, size) of every row (of the scenes named in `only`, if given): all
    scenes at E10's size first, then at each of `sizes`."""
    unknown = sorted(set(only or ()) - {name for name, _ in e10.SCENES})
    if unknown:
        raise FramesInputError(f"--scene {', '.join(unknown)}: E10's scenes are "
                               f"{', '.join(n for n, _ in e10.SCENES)}")
    out = []
    for size in dict.fromkeys([E10_SIZE, *sizes]):
        for name, spec in e10.SCENES:
            if not only or name in only:
                out += [(name, spec, ov, size) for ov in e10.configs(e10.FULL, spec)]
    return out


def measure(out: Path, frames: int, warmup: int, sizes: list[tuple[int, int]], only: list[str] | None = None
            ) -> None:
    """Time every row of `rows(sizes, only)` here and keep them in `out` (the module docstring)."""
    if frames < 1 or warmup < 0:
        raise FramesInputError(f"--frames {frames} --warmup {warmup}: at least one timed frame, no negative warm-up")
    todo = rows(sizes, only)
    out.mkdir(parents=True, exist_ok=True)
    # E10's rows are known to leave effects out (the direct row has no occlusion): one line each is noise here
    warnings.simplefilter("ignore", UnsimulatedEffectWarning)
    warnings.simplefilter("ignore", TechniqueNotRunWarning)
    info = get_context().info  # the context's limits, e.g. the storage block size VCT's 128^3 scratch exceeds
    doc: dict = {"gl": renderer_name(), "software_gl": is_software(), "frames": frames, "warmup_frames": warmup,
                 "gl_limits": {k: info[k] for k in sorted(info) if k.startswith("GL_MAX_")}, "rows": []}
    images: dict[str, np.ndarray] = {}
    t_start = time.perf_counter()
    print(f"OpenGL renderer: {doc['gl']}; {len(todo)} rows", flush=True)
    for i, (name, spec, ov, size) in enumerate(todo):
        scene = scenes.load(spec)
        extra = {"realtime.timing_frames": frames, "realtime.warmup_frames": warmup,
                 "camera.width": size[0], "camera.height": size[1]}
        t0 = time.perf_counter()
        r = realtime.render(scene.with_overrides({**ov, **extra}))
        key = row_key(name, ov, size)
        doc["rows"].append({
            "key": key, "scene": name, "overrides": ov, "size": list(r.rgb.shape[1::-1]),
            "mode": e10.mode(SimpleNamespace(techniques=r.meta["techniques"])),
            "setting": e10.setting(SimpleNamespace(overrides=ov)), "timings": r.timings,
            "wall_s": time.perf_counter() - t0, "nonfinite": int(np.count_nonzero(~np.isfinite(r.rgb)))})
        if size == E10_SIZE:
            # a non-finite value stays visible in the row's count and as float16's NaN or +-65504 in the image
            images[f"{key}|rgb"], doc["rows"][-1]["clamped"] = to_float16(r.rgb)
            images[f"{key}|mask"] = r.mask
            with atomic_output(out / "images.npz") as tmp, tmp.open("wb") as f:
                np.savez_compressed(f, **images)
        write_bytes(out / "frames.json", (json.dumps(doc, indent=1) + "\n").encode())
        print(f"[{i + 1}/{len(todo)}] {time.perf_counter() - t_start:7.1f} s  {key}: "
              f"{r.timings['total']:.3f} ms", flush=True)


def load(folder: Path) -> tuple[dict, dict[str, np.ndarray]]:
    """(frames.json's document, the images of images.npz or {} without it) of a run's folder."""
    if not (folder / "frames.json").is_file():
        raise FramesInputError(f"{folder}: no frames.json (the folder `measure --out` writes)")
    doc = json.loads((folder / "frames.json").read_text())
    path = folder / "images.npz"
    images = dict(np.load(path)) if path.exists() else {}
    return doc, images


def agreement(gpu_rgb: np.ndarray, gpu_mask: np.ndarray, cpu_rgb: np.ndarray, cpu_mask: np.ndarray,
              scene: scenes.Scene) -> tuple[float | None, int]:
    """(PSNR of the GPU's displayed image against the CPU's over the pixels both cover eroded by one, as every
    iblcheck metric's mask; the pixels only one covers)."""
    both = metrics.common_mask(gpu_mask, cpu_mask)
    shown_gpu = metrics.display(scene, gpu_rgb.astype(np.float32))
    shown_cpu = metrics.display(scene, cpu_rgb.astype(np.float32))
    return metrics.psnr(shown_gpu, shown_cpu, both), int((gpu_mask ^ cpu_mask).sum())


@dataclass
class RunPair:
    """A GPU run and a CPU run of the same rows (each `load`ed), and their images' `agreement` per row key
    where both runs kept the row's image, computed once."""

    gpu: dict
    gpu_images: dict[str, np.ndarray]
    cpu: dict
    cpu_images: dict[str, np.ndarray]
    agreed: dict[str, tuple[float | None, int]] = field(init=False)

    def __post_init__(self) -> None:
        self.agreed = {}
        for name, spec in e10.SCENES:
            keys = [r["key"] for r in self.gpu["rows"] if r["scene"] == name
                    and f"{r['key']}|rgb" in self.gpu_images and f"{r['key']}|rgb" in self.cpu_images]
            scene = scenes.load(spec) if keys else None
            for k in keys:
                self.agreed[k] = agreement(self.gpu_images[f"{k}|rgb"], self.gpu_images[f"{k}|mask"],
                                           self.cpu_images[f"{k}|rgb"], self.cpu_images[f"{k}|mask"], scene)


def load_pair(gpu_dir: Path, cpu_dir: Path) -> RunPair:
    return RunPair(*load(gpu_dir), *load(cpu_dir))


def setting_label(setting: list[int] | None) -> str:
    """A row's VCT setting as resolution x cascades x cones, '-' for a row without one."""
    return "x".join(str(v) for v in setting) if setting else "-"


def compare(pair: RunPair) -> list[str]:
    """Markdown lines: one table row per row of the GPU run, beside the CPU run's where it has it, and a closing
    line on the images (how many compared, the lowest PSNR, those under AGREE_DB)."""
    gpu, cpu = pair.gpu, pair.cpu
    cpu_rows = {r["key"]: r for r in cpu["rows"]}
    lines = [f"GPU: {gpu['gl']} ({gpu['frames']} timed frames after {gpu['warmup_frames']}); "
             f"CPU: {cpu['gl']} ({cpu['frames']} after {cpu['warmup_frames']}). Milliseconds are medians; "
             "the CPU's are llvmpipe's, that is CPU time. `trace` is the shading pass's ms less the direct row's.",
             "",
             "| scene | size | mode | resolution x cascades x cones | GPU frame ms | CPU frame ms | CPU / GPU "
             "| GPU voxelize ms | GPU trace ms | image PSNR dB, GPU vs CPU | pixels one covers |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    direct = {(r["scene"], tuple(r["size"])): r["timings"]["draw"] for r in gpu["rows"]
              if r["mode"] == "direct (paper)"}

    def cell(v: float | None, fmt: str = "{:.2f}") -> str:
        return "-" if v is None else fmt.format(v)

    for r in gpu["rows"]:
        c = cpu_rows.get(r["key"])
        t = r["timings"]
        base = direct.get((r["scene"], tuple(r["size"])))
        trace = t["draw"] - base if r["setting"] and base is not None else None
        psnr, differ = pair.agreed.get(r["key"], (None, None)) if c else (None, None)
        cpu_ms = c["timings"]["total"] if c else None
        lines.append(
            f"| {r['scene']} | {r['size'][0]}x{r['size'][1]} | {r['mode']} | {setting_label(r['setting'])} "
            f"| {t['total']:.2f} | {cell(cpu_ms)} | {cell(cpu_ms / t['total'] if cpu_ms else None, '{:.0f}')} "
            f"| {cell(t.get('voxelize'))} | {cell(trace)} | {cell(psnr)} | {cell(differ, '{}')} |")
    agreed = [(v, k) for k, (v, _) in pair.agreed.items() if v is not None and k in cpu_rows]
    if agreed:
        low, key = min(agreed)
        under = [k for v, k in agreed if v < AGREE_DB]
        lines += ["", f"Images: {len(agreed)} rows compared; the lowest PSNR {low:.2f} dB ({key}); "
                  + (f"{len(under)} under {AGREE_DB:.0f} dB: {'; '.join(under)}." if under
                     else f"all at {AGREE_DB:.0f} dB or more.")]
    return lines


def worst_rows(pair: RunPair) -> dict[str, tuple[float, dict]]:
    """{scene: (PSNR, row)} of each scene's row whose GPU and CPU images differ most (the lowest PSNR)."""
    worst: dict[str, tuple[float, dict]] = {}
    for r in pair.gpu["rows"]:
        v = pair.agreed.get(r["key"], (None, 0))[0]
        if v is not None and (r["scene"] not in worst or v < worst[r["scene"]][0]):
            worst[r["scene"]] = (v, r)
    return worst


def plot_differences(pair: RunPair, path: Path) -> None:
    """Per scene, the 192 x 192 row whose GPU and CPU images differ most (`worst_rows`): the GPU's image, the
    CPU's, and log10 of their largest per-channel difference in linear radiance where either covers."""
    worst = worst_rows(pair)
    if not worst:
        raise FramesInputError("no row has images in both runs (images.npz) to compare")
    plt = plots.pyplot()
    fig, axes = plt.subplots(len(worst), 3, figsize=(9, 3.0 * len(worst)), squeeze=False)
    for row, (name, (v, r)) in zip(axes, worst.items(), strict=True):
        scene = scenes.load(dict(e10.SCENES)[name])
        k = r["key"]
        a = pair.gpu_images[f"{k}|rgb"].astype(np.float32)
        b = pair.cpu_images[f"{k}|rgb"].astype(np.float32)
        either = pair.gpu_images[f"{k}|mask"] | pair.cpu_images[f"{k}|mask"]
        row[0].imshow(np.clip(metrics.display(scene, a), 0, 1))
        row[0].set_title(f"{pair.gpu['gl'].split('/')[0].strip()}", fontsize=9)
        row[1].imshow(np.clip(metrics.display(scene, b), 0, 1))
        row[1].set_title(f"{pair.cpu['gl'].split('(')[0].strip()}: {v:.2f} dB apart", fontsize=9)
        diff = np.where(either, np.log10(np.abs(a - b).max(axis=-1) + 1e-7), np.nan)
        im = row[2].imshow(diff, vmin=-6, vmax=0, cmap="magma")
        row[2].set_title("log10 |difference|, linear radiance", fontsize=9)
        fig.colorbar(im, ax=row[2], fraction=0.046)
        setting = f" {setting_label(r['setting'])}" if r["setting"] else ""
        row[0].set_ylabel(f"{name}\n{r['mode']}{setting}", fontsize=9)
        for ax in row:
            ax.set_xticks([])
            ax.set_yticks([])
    plots.save(fig, path)


def e10_psnr(summary: str) -> dict[tuple[str, str, tuple[int, int, int] | None], tuple[float, bool]]:
    """{(scene, mode, (resolution, cascades, cones) or None): (unbiased PSNR dB, whether E10 marks it "(floor)",
    a lower bound)} from E10's row table in the paper summary (reports/paper/summary.md, written by
    experiments/paper/e10_voxel_cone_tracing.py); rows without a PSNR are left out."""
    if "\n## E10 " not in summary:
        raise FramesInputError("the paper summary has no E10 section (## E10 ...)")
    section = summary.split("\n## E10 ", 1)[1].split("\n## ", 1)[0]
    names = {name for name, _ in e10.SCENES}
    out = {}
    for line in section.splitlines():
        cells = [c.strip().replace("\\", "") for c in line.strip().strip("|").split("|")]
        if len(cells) != 12 or cells[0] not in names or cells[1] not in e10.MODES or cells[5] == "-":
            continue
        setting = tuple(int(c) for c in cells[2:5]) if cells[2] != "-" else None
        out[(cells[0], cells[1], setting)] = (float(cells[5].split()[0]), "(floor)" in cells[5])
    if not out:
        raise FramesInputError("the paper summary's E10 section has no row table")
    return out


def plot_ladder(gpu_dir: Path, summary: Path, path: Path) -> None:
    """One panel per scene: E10's unbiased PSNR (at 192 x 192) against the GPU's frame ms (log), filled at
    192 x 192, open at the larger size, one colour per mode; a triangle where the PSNR is a lower bound."""
    gpu, _ = load(gpu_dir)
    if not summary.is_file():
        raise FramesInputError(f"{summary}: no such paper summary")
    psnr = e10_psnr(summary.read_text())
    plt = plots.pyplot()
    fig, axes = plt.subplots(1, len(e10.SCENES), figsize=(5.2 * len(e10.SCENES), 4.4), squeeze=False)
    colours = {m: f"C{k}" for k, m in enumerate(e10.MODES)}
    larger = ", ".join(dict.fromkeys(f"{w}x{h}" for w, h in (r["size"] for r in gpu["rows"]) if (w, h) != E10_SIZE))
    gl = gpu["gl"].split("/")[0].strip()
    for ax, (name, _) in zip(axes[0], e10.SCENES, strict=True):
        for r in gpu["rows"]:
            key = (name, r["mode"], tuple(r["setting"]) if r["setting"] else None)
            if r["scene"] != name or key not in psnr:
                continue
            value, floor = psnr[key]
            small = tuple(r["size"]) == E10_SIZE
            ax.scatter(r["timings"]["total"], value, s=28, marker="^" if floor else "o",
                       facecolors=colours[r["mode"]] if small else "none", edgecolors=colours[r["mode"]])
        ax.set_xscale("log")
        ax.set_title(name)
        ax.set_xlabel(f"frame ms on {gl}: filled {E10_SIZE[0]}x{E10_SIZE[1]}" + (f", open {larger}" if larger else ""))
        ax.set_ylabel(f"unbiased PSNR dB at {E10_SIZE[0]}x{E10_SIZE[1]} (E10)")
        ax.grid(True, which="both", alpha=0.3)
    handles = [plt.Line2D([], [], marker="o", ls="", color=colours[m], label=m) for m in e10.MODES]
    # torus-phong's empty middle left (in bowl-diffuse's, it covered the direct row)
    axes[0][-1].legend(handles=handles, fontsize=8, loc="center left")
    plots.save(fig, path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    m = sub.add_parser("measure", help="time E10's real-time rows here")
    m.add_argument("--out", type=Path, required=True, help="folder for frames.json and images.npz")
    m.add_argument("--frames", type=int, default=20, help="timed frames a row (medians and p90 over them)")
    m.add_argument("--warmup", type=int, default=3, help="untimed frames before them")
    m.add_argument("--size", type=parse_size, action="append", default=[],
                   help="also time every row at WIDTHxHEIGHT (images are kept at E10's 192x192 only)")
    m.add_argument("--scene", action="append", help="only this E10 scene (repeatable; default all three)")
    c = sub.add_parser("compare", help="a GPU run beside a CPU run of the same rows")
    c.add_argument("gpu", type=Path, help="the GPU run's folder")
    c.add_argument("cpu", type=Path, help="the CPU (llvmpipe) run's folder")
    c.add_argument("--markdown", type=Path, help="also write the table to this file")
    c.add_argument("--figure", type=Path, help="per scene, the row whose two images differ most")
    lad = sub.add_parser("ladder", help="E10's PSNR against the GPU's frame ms, one panel per scene")
    lad.add_argument("gpu", type=Path, help="the GPU run's folder")
    lad.add_argument("--summary", type=Path, default=ROOT / "reports" / "paper" / "summary.md")
    lad.add_argument("--out", type=Path, required=True, help="the figure (PNG)")
    args = ap.parse_args(argv)
    try:
        if args.command == "measure":
            rows(args.size, args.scene)  # an unknown scene is refused before anything renders
            measure(args.out, args.frames, args.warmup, args.size, args.scene)
        elif args.command == "ladder":
            plot_ladder(args.gpu, args.summary, args.out)
        else:
            pair = load_pair(args.gpu, args.cpu)
            lines = compare(pair)
            print("\n".join(lines))
            if args.markdown:
                args.markdown.write_text("\n".join(lines) + "\n")
            if args.figure:
                plot_differences(pair, args.figure)
    except FramesInputError as e:
        print(f"e10_frames: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
