"""`iblcheck report DIR`: DIR/index.html (one page) and DIR/summary.md from DIR/results.jsonl.

The page holds, for every configuration, the real-time image, the reference, the error heat map
and the FLIP map side by side; a sortable table of every metric; and the plots (also written as
PNG files under DIR/figures): PSNR and SSIM against LOD bias per face size, PSNR against frame
time with the Pareto front, filter and draw time against face size. Extra sections (the paper
suite's experiments) come before them.
"""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass, field
from pathlib import Path

from . import plots
from .results import ResultRow, store_in

#: the paper suite's sections, kept so that `iblcheck report` can rebuild its page
SECTIONS = "experiments.json"
COLUMNS = [("scene", True), ("techniques", True), ("face", False), ("material", True), ("N", False),
           ("f0", False), ("env", True), ("PSNR dB", False), ("unbiased dB", False), ("floor dB", False),
           ("SSIM", False), ("FLIP", False), ("relMSE", False), ("filter ms", False), ("draw ms", False),
           ("total ms", False), ("precompute ms", False), ("unsimulated", True)]


@dataclass
class Section:
    title: str
    html: str
    markdown: str
    figures: list[str] = field(default_factory=list)  # PNG paths relative to the report folder


def fmt(value, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def env_name(env: str) -> str:
    return env.split(":", 1)[1] if env.startswith("builtin:") else Path(env).name


def table_cells(r: ResultRow) -> list[str]:
    ms = r.realtime_ms
    return [r.scene, r.technique_label, str(r.face_size), r.material, fmt(r.exponent, "g"), fmt(r.f0, "g"),
            env_name(r.env), fmt(r.psnr, ".2f"), fmt(r.psnr_unbiased, ".2f"), fmt(r.noise_floor_psnr, ".2f"),
            fmt(r.ssim, ".4f"), fmt(r.flip, ".4f"), fmt(r.rel_mse, ".3g"), fmt(ms.get("filter"), ".2f"),
            fmt(ms.get("draw"), ".2f"), fmt(ms.get("total"), ".2f"), fmt(ms.get("precompute"), ".1f"),
            ", ".join(r.unsimulated_effects) or "-"]


def label(r: ResultRow) -> str:
    mats = "; ".join(" ".join(f"{k}={fmt(v, 'g') if isinstance(v, float) else v}" for k, v in m.items()
                              if k not in ("kd", "ks")) for m in r.materials)
    return f"{r.scene}: {r.technique_label}, face {r.face_size}, {mats}, {env_name(r.env)}"


def _inline(path: Path) -> str:
    return base64.b64encode(path.read_bytes()).decode()


def build(out_dir: Path, title: str = "iblcheck sweep", sections: list[Section] | None = None,
          rows: list[ResultRow] | None = None, subtitle: str = "") -> Path:
    """Write out_dir/index.html and out_dir/summary.md; returns the HTML path."""
    from jinja2 import Environment, PackageLoader, select_autoescape

    out_dir = Path(out_dir)
    saved = out_dir / SECTIONS
    if sections is None and saved.is_file():
        meta = json.loads(saved.read_text())
        sections = [Section(**d) for d in meta["sections"]]
        title, subtitle = meta.get("title", title), subtitle or meta.get("subtitle", "")
    if rows is None:
        rows = store_in(out_dir).read()
    figdir = out_dir / "figures"
    figdir.mkdir(parents=True, exist_ok=True)
    plot_list = []
    for name, fn, alt in (("psnr_ssim_vs_lod_bias.png", plots.accuracy_vs_bias, "PSNR and SSIM against LOD bias"),
                          ("psnr_vs_frame_time.png", plots.accuracy_vs_time, "PSNR against frame time"),
                          ("time_vs_face_size.png", plots.cost_vs_size, "filter and draw time against face size")):
        if rows and fn(rows, figdir / name):
            plot_list.append({"file": f"figures/{name}", "data": _inline(figdir / name), "alt": alt})
    view_rows = [{"cells": table_cells(r), "at_floor": r.at_noise_floor, "images": r.images,
                  "label": label(r), "psnr": fmt(r.psnr, ".2f")} for r in rows]
    env = Environment(loader=PackageLoader("experiments", "templates"), autoescape=select_autoescape())
    html = env.get_template("report.html.j2").render(
        title=title, subtitle=subtitle or f"{len(rows)} configurations", sections=sections or [], plots=plot_list,
        rows=view_rows, columns=[{"title": t, "left": left} for t, left in COLUMNS])
    index = out_dir / "index.html"
    index.write_text(html)
    (out_dir / "summary.md").write_text(summary_markdown(title, rows, sections or [], plot_list))
    return index


def summary_markdown(title: str, rows: list[ResultRow], sections: list[Section], plot_list: list[dict]) -> str:
    lines = [f"# {title}", ""]
    for s in sections:
        lines += [f"## {s.title}", "", s.markdown.strip(), ""]
        lines += [f"![{s.title}]({f})" for f in s.figures]
        lines.append("")
    if rows:
        best = {}
        for r in rows:
            key = (r.scene, r.material, r.exponent, r.f0, env_name(r.env))
            if r.psnr is not None and (key not in best or r.psnr > best[key].psnr):
                best[key] = r
        lines += ["## Best configuration per scene and material", "",
                  "| scene | material | N | f0 | env | techniques | face | PSNR dB | floor dB | SSIM | total ms |",
                  "|---|---|---:|---:|---|---|---:|---:|---:|---:|---:|"]
        for (name, mat, n, f0, env), r in sorted(best.items(), key=str):
            lines.append(f"| {name} | {mat} | {fmt(n, 'g')} | {fmt(f0, 'g')} | {env} | {r.technique_label} | "
                         f"{r.face_size} | {fmt(r.psnr, '.2f')} | {fmt(r.noise_floor_psnr, '.2f')} | "
                         f"{fmt(r.ssim, '.4f')} | {fmt(r.realtime_ms.get('total'), '.2f')} |")
        lines.append("")
    lines += [f"![{p['alt']}]({p['file']})" for p in plot_list]
    return "\n".join(lines) + "\n"
