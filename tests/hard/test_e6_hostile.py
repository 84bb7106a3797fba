"""E6 of the paper suite lists the hostile-input classes, and every case there comes out as expected."""

from __future__ import annotations

import ast
import shutil
from pathlib import Path

import pytest

from experiments.cli.main import COMMAND_LINE
from experiments.paper import e06_stability as stability
from experiments.paper.context import CommandLine
from experiments.paper.e06_hostile_limits import LimitsAndTrustCases
from experiments.paper.e06_hostile_runs import HostileCases

CLASSES = list(stability.HOSTILE_CLASSES)


@pytest.fixture(scope="module")
def rows(tmp_path_factory):
    cases = LimitsAndTrustCases(spp=16, command_line=COMMAND_LINE)
    out = []
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("IBLCHECK_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))
        try:
            for part in cases.parts():
                out += part()
        finally:
            shutil.rmtree(cases.tmp, ignore_errors=True)
    return out


@pytest.mark.gl
@pytest.mark.mitsuba
@pytest.mark.slow
def test_every_hostile_class_is_in_e6_and_every_case_is_as_expected(rows):
    assert [c for c in CLASSES if any(r["class"] == c for r in rows)] == CLASSES
    unexpected = [(r["class"], r["case"], r["outcome"][:200]) for r in rows if not r["ok"]]
    assert not unexpected, unexpected
    assert len(rows) >= 60


@pytest.mark.gl
@pytest.mark.mitsuba
@pytest.mark.slow
def test_the_e6_section_shows_the_class_of_each_case(rows, monkeypatch):
    section = stability.section(rows)
    table = next(b for b in section.blocks if b["kind"] == "table")
    assert table["header"][0] == "class" and len(table["rows"]) == len(rows)
    note = next(b for b in section.blocks if b["kind"] == "text")["text"]
    for c in CLASSES:
        assert f"{c}: " in note
    assert "| class | case |" in section.markdown


def test_e6_runs_its_own_parts_and_then_the_hostile_ones():
    cases, hostile = stability.Cases(16), LimitsAndTrustCases(16, COMMAND_LINE)
    try:
        groups = stability.parts(cases, hostile)
        assert len(groups) == stability.count_parts() == 20
        assert [c for c, _ in groups[:6]] == list(stability.CLASSES.values())
        assert [p.__name__ for _, p in groups[6:]] == ["escaping", "output_paths", "exit_codes", "misreads",
                                                       "back_faces", "stale_sweeps", "machine_limits", "tiny_maps",
                                                       "trusted_files", "empty_comparisons", "strict_gltf",
                                                       "markdown", "what_ran", "smaller_promises"]
    finally:
        shutil.rmtree(cases.tmp, ignore_errors=True)
        shutil.rmtree(hostile.tmp, ignore_errors=True)


def test_the_hostile_cases_run_the_command_line_they_are_handed(tmp_path):
    """E6 reaches `iblcheck` only through the CommandLine it is given (the paper layer does not import
    experiments.cli): a recording stand-in sees the exact argv and its exit code comes back."""
    seen = []
    fake = CommandLine(main=lambda argv: seen.append(argv) or 7, run_command=lambda args: 0)
    hostile = HostileCases(16, fake)
    try:
        assert hostile.cli("render", "x.toml") == (7, "", "")
        assert seen == [["render", "x.toml"]]
        code, _, err = HostileCases(16, COMMAND_LINE).cli("paper", "--only", "E99")  # the real one
        assert code == 2 and "--only" in err and "E99" in err
    finally:
        shutil.rmtree(hostile.tmp, ignore_errors=True)


def test_no_module_of_the_paper_suite_imports_the_command_line():
    """Every import in experiments/paper, module level or inside a function: none names experiments.cli
    (negative control: the command line's own main.py does import the paper suite)."""
    def imports(path: Path) -> set[str]:
        out = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                out |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.module:
                out |= {node.module} | {f"{node.module}.{a.name}" for a in node.names}
        return out

    root = Path(__file__).resolve().parents[2] / "experiments"
    paper = sorted((root / "paper").glob("*.py"))
    assert len(paper) >= 14
    bad = {p.name: sorted(m for m in imports(p) if m.startswith("experiments.cli")) for p in paper}
    assert not any(bad.values()), bad
    assert any(m.startswith("experiments.paper") for m in imports(root / "cli" / "main.py"))
