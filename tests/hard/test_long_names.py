"""A scene name of 10,000 characters keeps the report's tables usable: a cell shows at most about
CELL_LIMIT characters, cut in the middle, and holds the whole name (escaped) in its tooltip; short
names are untouched (the control)."""

from __future__ import annotations

import html
import re

from experiments.publish import report

LONG = "<b>x</b>" + "n" * 10_000 + "END"


def page_with(name: str) -> str:
    section = report.Section("s", [report.table(["scene", "PSNR dB"], [[name, "31.20"]])], "")
    return report.render_page(title="t", subtitle="", sections=[section], plots=[], rows=[], columns=[])


def cells(page: str) -> list[str]:
    return re.findall(r"<td>(.*?)</td>", page, flags=re.S)


def test_a_long_name_is_cut_for_display_with_the_whole_in_its_tooltip():
    cell = cells(page_with(LONG))[0]
    shown = re.sub(r"<[^>]+>", "", cell)
    assert len(html.unescape(shown)) <= report.CELL_LIMIT + 40
    assert "characters left out" in shown and html.unescape(shown).endswith("END")
    title = re.search(r'title="([^"]*)"', cell).group(1)
    assert html.unescape(title) == LONG  # the whole name, escaped
    assert "<b>" not in cell  # the markup of the name stays text


def test_control_short_names_and_numbers_stay_as_they_are():
    assert cells(page_with("sphere-diffuse")) == ["sphere-diffuse", "31.20"]
