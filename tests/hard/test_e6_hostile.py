"""E6 of the paper suite lists the hostile-input classes of issue 11, and every case there comes out as expected."""

from __future__ import annotations

import pytest

from experiments.paper import e06_stability as stability
from experiments.paper import suite as paper
from experiments.paper.e06_hostile_runs import HostileCases

CLASSES = ["escaping", "output paths", "exit codes", "silent misreads", "back faces", "stale sweeps"]


@pytest.fixture(scope="module")
def rows(tmp_path_factory):
    import shutil

    cases = HostileCases(spp=16)
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
    monkeypatch.setattr(stability, "run", lambda spp, progress: rows)
    section = paper.e6_section(16, lambda: None)
    table = next(b for b in section.blocks if b["kind"] == "table")
    assert table["header"][0] == "class" and len(table["rows"]) == len(rows)
    note = next(b for b in section.blocks if b["kind"] == "text")["text"]
    for c in CLASSES:
        assert f"{c}: " in note
    assert "| class | case |" in section.markdown


def test_e6_runs_its_own_parts_and_then_the_hostile_ones():
    cases, hostile = stability.Cases(16), HostileCases(16)
    try:
        groups = stability.parts(cases, hostile)
        assert len(groups) == stability.count_parts() == 12
        assert [c for c, _ in groups[:6]] == list(stability.CLASSES.values())
        assert [p.__name__ for _, p in groups[6:]] == ["escaping", "output_paths", "exit_codes", "misreads",
                                                       "back_faces", "stale_sweeps"]
    finally:
        import shutil

        shutil.rmtree(cases.tmp, ignore_errors=True)
        shutil.rmtree(hostile.tmp, ignore_errors=True)
