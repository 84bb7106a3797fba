"""Markdown that iblcheck writes renders a user's name as its text, never as Markdown syntax.

`gate --markdown` and summary.md are posted as pull-request comments, where a scene name such as
`[x](http://evil)` would become a link. Every name goes through `experiments.publish.text.md_cell`;
these tests render the output with a CommonMark renderer (markdown-it-py's "commonmark" preset) and a
GFM renderer (cmark-gfm, GitHub's own, through `cmarkgfm`) and check the HTML: no element but the
table's and the paragraph's, and the name's text (made visible) intact.
"""

from __future__ import annotations

import html
import re

import pytest

from experiments.publish import report, text
from experiments.runs import gate

markdown_it = pytest.importorskip("markdown_it")
cmarkgfm = pytest.importorskip("cmarkgfm")

HOSTILE = [
    "[click](http://evil.example/x)", "![pixel](http://evil.example/p.png)", "*em* _em_", "**strong** __strong__",
    "`code`", "``a ` b``", "<http://evil.example>", "http://evil.example/a?b=c", "www.evil.example",
    "mail me: a.b@evil.example", "~~gone~~", "~one~", "<b>bold</b>", "<!-- hidden -->", "&lt;script&gt;",
    "&#60;img src=x&#62;", "a | b | c", "a \\| b", "\\", "trailing \\", "[ref][1]\n\n[1]: http://evil.example",
    "[^note]", "# heading", "- item", "1. item", "> quote", "    indented code", "```fence```", "x<sup>2</sup>",
    "[x]: http://evil.example", "<javascript:alert(1)>", "[a](<http://e x>)", "\\*not em\\*", "***both***",
    "a_b_c snake_case_name", "2 * 3 * 4", "[![img](http://e/i.png)](http://e)", "- [ ] task", ":smile: @user #12",
    "\x1b[31mred\x1b[0m", "\u202eevil", "{{ 7*7 }}", "$x^2$",
]
#: elements a rendered name must not produce (the table's own th/td/tr and the paragraph are allowed)
FORBIDDEN = re.compile(r"<(a|img|em|strong|code|del|s|pre|h\d|ul|ol|li|blockquote|sup|script|b|input)\b", re.I)


def _text(rendered: str) -> str:
    """The text a reader sees in `rendered` HTML: tags removed, entities decoded, the WORD JOINERs that
    md_cell puts after `@` removed (invisible)."""
    return html.unescape(re.sub(r"<[^>]*>", "", rendered)).replace("\u2060", "").strip("\n")


@pytest.mark.parametrize("name", HOSTILE, ids=[f"md{i}" for i in range(len(HOSTILE))])
def test_a_name_renders_as_its_text_in_commonmark(name):
    out = markdown_it.MarkdownIt("commonmark").render(text.md_cell(name))
    assert not FORBIDDEN.search(out), out
    assert out.startswith("<p>") and out.count("<p>") == 1, out
    assert _text(out) == text.visible(name)


@pytest.mark.parametrize("name", HOSTILE, ids=[f"md{i}" for i in range(len(HOSTILE))])
def test_a_name_renders_as_its_text_in_a_gfm_table_cell(name):
    cell = text.md_cell(name)
    out = cmarkgfm.github_flavored_markdown_to_html(f"| {cell} | x |\n|---|---|\n| {cell} | y |\n")
    assert not FORBIDDEN.search(out), out
    cells = re.findall(r"<t[hd]>(.*?)</t[hd]>", out, re.S)
    assert [_text(c) for c in cells] == [text.visible(name), "x", text.visible(name), "y"], out


def test_plain_names_stay_readable():
    """Negative control: a name without punctuation is written as it is; with some, it still reads the same."""
    assert text.md_cell("sphere phong 2") == "sphere phong 2"
    assert text.md_cell("Café ñandú") == "Café ñandú"
    out = cmarkgfm.github_flavored_markdown_to_html(f"| {text.md_cell('sphere-phong_2.toml')} |\n|---|\n")
    assert "<th>sphere-phong_2.toml</th>" in out
    assert text.md_cell("sphere-blend") == "sphere-blend"  # a dash inside a name stays as it is


def test_gate_markdown_with_a_hostile_scene_renders_inert():
    name = "[x](http://evil.example) **b** `c` a@b.io"
    results = [gate.GateResult(name, {"psnr": 30.0, "ssim": 0.9, "flip": 0.1, "realtime_ms": {"total": 1.0}},
                               {"min_psnr": 40.0}, failures=[f"psnr of {name} = 30, required >= 40"],
                               warnings=[f"the map {name} differs"])]
    md = gate.markdown(results)
    out = cmarkgfm.github_flavored_markdown_to_html(md)
    assert not re.search(r"<(a|img|em|code)\b", out), out
    assert out.count(text.visible(name)) == 0  # the raw name is nowhere (it is escaped)...
    assert _text(out).count(name) == 5  # ...but reads the same: the row; the failure and warning lines twice
    assert "<strong>FAIL</strong>" in out  # negative control: iblcheck's own emphasis still renders


def test_summary_table_cells_render_inert():
    md = report.md_table(["scene", "value"], [["*a* [l](http://e)", "`1`"], ["ok", "2"]])
    out = cmarkgfm.github_flavored_markdown_to_html(md)
    assert not FORBIDDEN.search(out), out
    assert "<td>*a* [l](http://e)</td>" in out and "<td>`1`</td>" in out
