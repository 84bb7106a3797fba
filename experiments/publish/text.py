"""Text that leaves iblcheck for a terminal, an XML file or a Markdown file.

Scene names, file names and `--set` values are user text: a name may hold ANSI escape sequences,
newlines, NUL bytes, bidirectional overrides or bytes that are not UTF-8 (a file name decoded with
Python's surrogateescape). Before such text is printed or written outside HTML it goes through
one of these functions; HTML goes through Jinja's autoescape (experiments/publish/report.py).

- `visible(text)`: every control character (C0, DEL, C1), bidirectional control and undecodable
  byte is shown as an escape (`\\x1b`, `\\n`, `\\u202e`), so nothing reaches a terminal that it
  could interpret, and a name cannot start a new line.
- `one_line(text, limit)`: `visible`, then cut in the middle to `limit` characters (the end of an
  error line says what is allowed, so it is kept).
- `xml_text(text)`: `visible` (XML 1.0 forbids most control characters; a JUnit file with one
  does not parse).
- `html_text(value)`: Jinja's `finalize` for the report page: control characters as in `visible`
  (newlines and tabs kept: HTML whitespace); Jinja's autoescape then escapes the markup.
- `md_cell(text)`: `visible`, with `&`, `<`, `>` written as entities and the other Markdown-active
  characters backslash-escaped (CommonMark 0.31 section 2.4: an escaped ASCII punctuation character is
  literal text). So a name can neither end a Markdown table row (`|`), smuggle HTML, nor start a
  link, image, emphasis, code span, strikethrough, list, autolink or GFM bare-URL link (its `:` and
  `.` are escaped, which breaks the URL patterns; `@` is followed by an invisible U+2060 WORD JOINER,
  which breaks the email pattern); its text renders unchanged (but for that joiner).
- `comparison_table(rows)`: the plain-text table of `iblcheck compare`, every cell through `one_line`.
"""

from __future__ import annotations

import re

#: C0 controls (newline and tab included), DEL, C1 controls, bidirectional controls, lone surrogates
#: (undecodable bytes of a file name), U+FFFE/U+FFFF (not characters; invalid in XML)
_UNSAFE = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069\ud800-\udfff\ufffe\uffff]")
_NAMED = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}
#: an error or warning line longer than this is cut in the middle
LINE_LIMIT = 600


def _escape(m: re.Match) -> str:
    ch = m.group(0)
    if ch in _NAMED:
        return _NAMED[ch]
    code = ord(ch)
    if 0xDC80 <= code <= 0xDCFF:  # a byte that was not UTF-8, as surrogateescape keeps it
        return f"\\x{code - 0xDC00:02x}"
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def visible(text: object, keep: str = "") -> str:
    """`text` with every character a terminal or an XML parser could choke on shown as an escape
    (except the characters in `keep`, e.g. newlines in a block of HTML text)."""
    return _UNSAFE.sub(lambda m: m.group(0) if m.group(0) in keep else _escape(m), str(text))


def shorten(text: str, limit: int = LINE_LIMIT) -> str:
    """Cut `text` in the middle to at most about `limit` characters, saying how much was left out."""
    if len(text) <= limit:
        return text
    keep = max(limit - 40, 20)
    head, tail = keep * 2 // 3, keep - keep * 2 // 3
    return f"{text[:head]} ... ({len(text) - head - tail} characters left out) ... {text[len(text) - tail:]}"


def one_line(text: object, limit: int = LINE_LIMIT) -> str:
    """A single, safe, bounded line for a terminal (error and warning lines, table cells)."""
    return shorten(visible(text), limit)


def xml_text(text: object) -> str:
    """Text that an XML 1.0 document may hold (ElementTree escapes &, < and > itself)."""
    return visible(text)


#: the characters that are Markdown syntax anywhere in a line (CommonMark 0.31 and GFM inlines: escapes,
#: code spans, emphasis, links and images, raw HTML and entities, table pipes, strikethrough, autolinks
#: with their `:`, `.` and `@`) and on GitHub (`$` maths, `#` issue references), each written as
#: literal text: a backslash escape (CommonMark section 2.4: any ASCII punctuation may be escaped)
_MD_INLINE = re.compile(r"[\\`*_\[\]<>&|~!():@.$#]")
#: characters that start a block only at the start of a line (list items, setext underlines, thematic
#: breaks): escaped there only, so `sphere-blend` stays readable in the Markdown source
_MD_BLOCK_START = "-+="
#: `&`, `<`, `>` as entities (also safe where a renderer passes HTML through); GFM's email autolinks are
#: found in the text after escapes are resolved (`a\@b\.io` still becomes a mailto link in cmark-gfm):
#: an invisible WORD JOINER after `@` breaks the pattern, the text reads the same
_MD_ENTITY = {"&": "&amp;", "<": "&lt;", ">": "&gt;", "@": "\\@\u2060"}


def md_cell(text: object) -> str:
    """Markdown inline text (a table cell, a list item, a heading) that renders as exactly `text`
    made visible: one line, no raw HTML, no column separator, and no Markdown syntax (`_MD_INLINE`
    escaped everywhere, `_MD_BLOCK_START` at the start; `&`, `<`, `>` as entities; `@` also followed
    by U+2060, see `_MD_ENTITY`; leading and trailing spaces as `&#32;`)."""
    cell = _MD_INLINE.sub(lambda m: _MD_ENTITY.get(m.group(0)) or "\\" + m.group(0), visible(text))
    if cell and cell[0] in _MD_BLOCK_START:
        cell = "\\" + cell
    # leading spaces would start an indented code block, trailing ones a line break: as entities they are text
    body = cell.strip(" ")
    if not body:
        return "&#32;" * len(cell)
    start = cell.index(body)
    return "&#32;" * start + body + "&#32;" * (len(cell) - start - len(body))


def html_text(value: object) -> object:
    """Every `{{ value }}` of the report page before autoescape: strings made visible (see above)."""
    return visible(value, keep="\n\t") if isinstance(value, str) else value


#: the footnote of a PSNR marked `*` (comparison.compare's `at_noise_floor`)
AT_FLOOR_NOTE = ("* at the noise floor: within 1 dB of the reference's own noise, where a better image cannot "
                 "score higher; more reference.spp raises the floor")


def comparison_table(rows: list[dict]) -> str:
    """A plain-text table of `experiments.measure.comparison.compare` dicts for humans (`iblcheck compare`);
    every cell goes through `one_line`.

    Every per-frame timing key of the rows' `realtime_ms` has its column, so the frame time is the sum of
    the columns shown: filter, the chosen techniques' declared timing keys as they first appear (e.g.
    `lights`, `shadow`, `voxelize`, `mip`), draw, and the frame (`total`); a key a row lacks is `-`.
    `precompute` (once per scene, not per frame) and `background` (no method's) are left out. A PSNR at
    the noise floor (`at_noise_floor`) is marked `*`, with AT_FLOOR_NOTE under the table."""
    seen = dict.fromkeys(k for row in rows for k in (row.get("realtime_ms") or {}))
    own = [k for k in seen if k not in ("filter", "draw", "total", "precompute", "background")]
    timings = [(f"{'frame' if k == 'total' else k} ms", ("realtime_ms", k), "{:.2f}")
               for k in ("filter", *own, "draw", "total")]
    cols = [("scene", "scene", "{}"), ("PSNR dB", "psnr", "{:.2f}"), ("unbiased dB", "psnr_unbiased", "{:.2f}"),
            ("floor dB", "noise_floor_psnr", "{:.2f}"),
            ("SSIM", "ssim", "{:.4f}"), ("FLIP", "flip", "{:.4f}"), ("relMSE", "rel_mse", "{:.3g}"),
            *timings,
            ("ref s", "reference_s", "{:.1f}"), ("spp", "reference_spp", "{}"), ("pixels", "pixels", "{}")]

    def get(row, key):
        return (row.get(key[0]) or {}).get(key[1]) if isinstance(key, tuple) else row.get(key)

    cells = [[h for h, _, _ in cols]]
    for row in rows:
        cells.append(["-" if get(row, k) is None else one_line(f.format(get(row, k)), 80)
                      + ("*" if k == "psnr" and row.get("at_noise_floor") else "") for _, k, f in cols])
    widths = [max(len(r[i]) for r in cells) for i in range(len(cols))]
    lines = ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths, strict=True)))
             for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    if any(row.get("at_noise_floor") for row in rows):
        lines.append(AT_FLOOR_NOTE)
    return "\n".join(lines)
