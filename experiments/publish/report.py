"""`iblcheck report DIR`: DIR/index.html (one page) and DIR/summary.md from DIR/results.jsonl.

The page holds, for every configuration, the real-time image, the reference, the error heat map
and the FLIP map side by side; a sortable table of every metric; and the plots (also written as
PNG files under DIR/figures): PSNR and SSIM against LOD bias per face size, PSNR against frame
time with the Pareto front, filter and draw time against face size. Extra sections (the paper
suite's experiments) come before them.

The viewer: the rows table carries each row's scene, techniques and effects and the path of its data
file (`data-*` attributes); viewer/viewer.js (package data from experiments/publish/viewer/, copied
into DIR/viewer/) filters and sorts the tables and shows a row's linear images (the real-time image,
the reference and its second seed, the error and FLIP maps) with an exposure control, flip, swipe,
zoom and a pixel inspector. Its data are files beside the page, one per row and per reference,
loaded when a row is opened (experiments/publish/viewer_data.py).

Escaping: every value reaches the page through the template with autoescape on; a
section is data (`Section.blocks`: tables, paragraphs, lists, figures), never HTML. Image sources
are local paths or inline PNGs only. The page holds no inline script: its scripts are files in the
report folder, and the Content-Security-Policy (`CSP`) lets only scripts of the page's origin (over
HTTP) or file: URLs (from disk, where a policy cannot name one folder) run (no inline script, no eval)
and nothing load from the network, so a hostile name shows as text and runs nothing. The data
files are JSON with every non-ASCII character escaped (viewer_data.statement).
"""

from __future__ import annotations

import base64
import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from jinja2 import Environment, PackageLoader
from markupsafe import Markup

from experiments.measure.results import ResultRow, store_in
from experiments.publish import outputs, plots, viewer_data
from experiments.publish.text import html_text, md_cell, shorten, visible
from scenes import InputError

#: the paper suite's sections, kept so that `iblcheck report` can rebuild its page
SECTIONS = "experiments.json"
COLUMNS = [("scene", True), ("techniques", True), ("face", False), ("material", True), ("N", False),
           ("f0", False), ("env", True), ("PSNR dB", False), ("unbiased dB", False), ("floor dB", False),
           ("SSIM", False), ("FLIP", False), ("relMSE", False), ("filter ms", False), ("draw ms", False),
           ("total ms", False), ("precompute ms", False), ("unsimulated", True)]


@dataclass
class Section:
    """One section of a report: a title, its content as data (`blocks`, rendered by the template
    with autoescape), the same as Markdown (summary.md) and its figures."""

    title: str
    blocks: list[dict[str, Any]]  # made by table(), paragraph(), bullets(), figure()
    markdown: str
    figures: list[str] = field(default_factory=list)  # PNG paths relative to the report folder

    @classmethod
    def from_dict(cls, d: dict) -> Section:
        """A section saved in experiments.json. One saved before sections were data (it holds
        `html`) is shown as its Markdown text: stored HTML is never put into a page."""
        if "blocks" not in d:
            return cls(str(d.get("title", "")), [preformatted(d.get("markdown", ""))], str(d.get("markdown", "")),
                       list(d.get("figures", [])))
        return cls(str(d["title"]), list(d["blocks"]), str(d["markdown"]), list(d.get("figures", [])))


def table(header: list, rows: list[list]) -> dict:
    return {"kind": "table", "header": [str(h) for h in header], "rows": [[str(c) for c in r] for r in rows]}


def paragraph(text: str) -> dict:
    return {"kind": "text", "text": str(text)}


def preformatted(text: str) -> dict:
    return {"kind": "pre", "text": str(text)}


def bullets(items: list) -> dict:
    return {"kind": "list", "items": [str(i) for i in items]}


def figure(path: str, alt: str) -> dict:
    return {"kind": "figure", "src": str(path), "alt": str(alt)}


def md_block(markdown: str) -> str:
    """A section's Markdown as summary.md holds it: no raw HTML (< and > as entities; md_table's cells
    hold none already) and no control characters but newlines."""
    return visible(markdown, keep="\n").replace("<", "&lt;").replace(">", "&gt;")


def md_table(header: list, rows: list[list]) -> str:
    """A Markdown table; every cell escaped (text.md_cell)."""
    out = ["| " + " | ".join(md_cell(h) for h in header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(md_cell(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


_LOCAL = re.compile(r"^(?![a-zA-Z][a-zA-Z0-9+.-]*:)(?!/)(?!.*\.\.)[\w./-]+$")


def local_src(path: object) -> str:
    """An image source the page may load: a relative path inside the report folder, or ''."""
    text = str(path or "")
    return text if _LOCAL.match(text) else ""


def fmt(value, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def f2(x: float | None) -> str:
    """A table cell with two decimals; '-' for a value that was not measured (None)."""
    return fmt(x, ".2f")


def f3(x: float | None) -> str:
    """A table cell with three decimals; '-' for None."""
    return fmt(x, ".3f")


def f4(x: float | None) -> str:
    """A table cell with four decimals; '-' for None."""
    return fmt(x, ".4f")


def unbiased_cell(r: ResultRow) -> str:
    """A row's unbiased PSNR as a cell, '(floor)' when clamped at what the reference can resolve."""
    return f2(r.psnr_unbiased) + (" (floor)" if r.psnr_unbiased_clamped else "")


def best_row(rows: list[ResultRow], keep) -> ResultRow | None:
    """The row of highest unbiased PSNR among `rows` for which `keep(row)` is true; None if there is none."""
    ok = [r for r in rows if r.psnr_unbiased is not None and keep(r)]
    return max(ok, key=lambda r: r.psnr_unbiased) if ok else None


def env_name(env: str) -> str:
    return env.split(":", 1)[1] if env.startswith("builtin:") else Path(env).name


def table_cells(r: ResultRow) -> list[str]:
    ms = r.realtime_ms
    return [r.scene, r.technique_label, str(r.face_size or "-"), r.material, fmt(r.exponent, "g"), fmt(r.f0, "g"),
            env_name(r.env), fmt(r.psnr, ".2f"), fmt(r.psnr_unbiased, ".2f"), fmt(r.noise_floor_psnr, ".2f"),
            fmt(r.ssim, ".4f"), fmt(r.flip, ".4f"), fmt(r.rel_mse, ".3g"), fmt(ms.get("filter"), ".2f"),
            fmt(ms.get("draw"), ".2f"), fmt(ms.get("total"), ".2f"), fmt(ms.get("precompute"), ".1f"),
            ", ".join(r.unsimulated_effects) or "-"]


def label(r: ResultRow) -> str:
    mats = "; ".join(" ".join(f"{k}={fmt(v, 'g') if isinstance(v, float) else v}" for k, v in m.items()
                              if k not in ("kd", "ks") and not (k == "two_sided" and not v)) for m in r.materials)
    face = f", face {r.face_size}" if r.face_size else ""
    return f"{r.scene}: {r.technique_label}{face}, {mats}, {env_name(r.env)}"


def _inline(path: Path) -> str:
    return base64.b64encode(path.read_bytes()).decode()


def build(out_dir: Path, title: str = "iblcheck sweep", sections: list[Section] | None = None,
          rows: list[ResultRow] | None = None, subtitle: str = "") -> Path:
    """Write out_dir/index.html and out_dir/summary.md; returns the HTML path."""
    out_dir = Path(out_dir)
    saved = out_dir / SECTIONS
    if sections is None and saved.is_file():
        meta = read_sections(saved)
        sections = [Section.from_dict(d) for d in meta["sections"]]
        title, subtitle = str(meta.get("title", title)), subtitle or str(meta.get("subtitle", ""))
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
        else:
            # a plot these rows cannot draw: an earlier build's file would show rows that are gone
            (figdir / name).unlink(missing_ok=True)
    labels = {r.id: label(r) for r in rows}
    viewer_data.copy_assets(out_dir)
    data = viewer_data.write(out_dir, rows, labels)
    view_rows = [{"cells": table_cells(r), "at_floor": r.at_noise_floor,
                  "images": {k: local_src(r.images.get(k)) for k in ("realtime", "reference", "error", "flip")},
                  "label": labels[r.id], "psnr": fmt(r.psnr, ".2f"), "id": r.id, "scene": r.scene,
                  "technique": r.technique_label, "effects": " ".join(r.effects),
                  "data": local_src(data.rows.get(r.id)), "why": data.missing.get(r.id, "")} for r in rows]
    html = render_page(title=title, subtitle=subtitle or f"{len(rows)} configurations", sections=sections or [],
                       plots=plot_list, rows=view_rows, columns=[{"title": t, "left": left} for t, left in COLUMNS])
    index = out_dir / "index.html"
    outputs.write_text(index, html)
    outputs.write_text(out_dir / "summary.md", summary_markdown(title, rows, sections or [], plot_list))
    return index


def read_sections(path: Path) -> dict:
    """experiments.json of a paper report; an unreadable one is bad input naming the file."""
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(meta, dict) or not isinstance(meta.get("sections"), list) \
                or not all(isinstance(d, dict) for d in meta["sections"]):
            raise ValueError("no list of sections")
        return meta
    except (ValueError, RecursionError, UnicodeDecodeError) as exc:
        reason = "nested too deeply" if isinstance(exc, RecursionError) else "not the saved sections of a report"
        raise InputError(f"{path}: {reason}; delete it to rebuild the page from results.jsonl alone") from None


#: the page's scripts and style sheet: files in the report folder (viewer_data.copy_assets), never inline
SCRIPTS, STYLES = ("viewer/viewer.js",), ("viewer/viewer.css",)

#: the page's Content-Security-Policy. Scripts: only files of the report folder ('self' for a report
#: served over HTTP; `file:` for one opened from disk, where Chromium does not match 'self'); no inline
#: script and no eval ('unsafe-inline' and 'unsafe-eval' are absent). Styles: the page's own <style>
#: and the viewer's sheet. Images: local files and the inline plots. Nothing from the network.
CSP = ("default-src 'none'; script-src 'self' file:; style-src 'self' 'unsafe-inline' file:; "
       "img-src 'self' data: file:; base-uri 'none'; form-action 'none'")


#: the most characters of a name shown in a table cell of the page; the full name is its tooltip
CELL_LIMIT = 80


def clip(value: object, limit: int = CELL_LIMIT) -> object:
    """A table cell: short strings as they are; a longer one cut in the middle (text.shorten) with the
    whole, escaped, in its `title` tooltip, so a 10,000-character scene name keeps the table usable."""
    if not isinstance(value, str) or len(value) <= limit:
        return value
    full = html_text(value)
    return Markup('<span title="{}">{}</span>').format(full, shorten(full, limit))


def render_page(**context) -> str:
    """The report page from report.html.j2, autoescaped, with its Content-Security-Policy."""
    env = Environment(loader=PackageLoader("experiments.publish", "templates"), autoescape=True,
                      finalize=lambda v: v if isinstance(v, Markup) else html_text(v))  # clip's escaped cells
    env.filters["local_src"] = local_src
    env.filters["clip"] = clip
    return env.get_template("report.html.j2").render(csp=CSP, scripts=SCRIPTS, styles=STYLES, **context)


def summary_markdown(title: str, rows: list[ResultRow], sections: list[Section], plot_list: list[dict]) -> str:
    lines = [f"# {md_cell(title)}", ""]
    for s in sections:
        lines += [f"## {md_cell(s.title)}", "", md_block(s.markdown).strip(), ""]
        lines += [f"![{md_cell(s.title)}]({local_src(f)})" for f in s.figures]
        lines.append("")
    if rows:
        best = {}
        for r in rows:
            # each engine image is its own row: the best of several engines' images is no configuration to pick
            image = r.technique_label if r.is_engine_image else None
            key = (r.scene, r.material, r.exponent, r.f0, env_name(r.env), image)
            if r.psnr is not None and (key not in best or r.psnr > best[key].psnr):
                best[key] = r
        lines += ["## Best configuration per scene and material", "",
                  "| scene | material | N | f0 | env | techniques | face | PSNR dB | floor dB | SSIM | total ms |",
                  "|---|---|---:|---:|---|---|---:|---:|---:|---:|---:|"]
        for (name, mat, n, f0, env, _), r in sorted(best.items(), key=str):
            cells = [name, mat, fmt(n, "g"), fmt(f0, "g"), env, r.technique_label, r.face_size or "-",
                     fmt(r.psnr, ".2f"), fmt(r.noise_floor_psnr, ".2f"), fmt(r.ssim, ".4f"),
                     fmt(r.realtime_ms.get("total"), ".2f")]
            lines.append("| " + " | ".join(md_cell(c) for c in cells) + " |")
        lines.append("")
    lines += [f"![{p['alt']}]({p['file']})" for p in plot_list]
    return "\n".join(lines) + "\n"
