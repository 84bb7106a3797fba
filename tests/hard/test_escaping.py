"""Everything that reaches HTML, XML, Markdown or a terminal is escaped.

Hostile names (experiments/paper/e06_hostile_cases.py: markup, script URLs, template syntax, mathtext, terminal escapes,
control characters, bidirectional overrides) go into every field that carries text: the scene name, the
map and mesh file names, `--set` values and sweep axis values; the report page runs none of them (checked
by parsing it, and in headless Chromium when it is installed), the summary and the JUnit file stay well
formed, and no terminal line carries a control character.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from experiments.cli import main as cli
from experiments.paper import e06_hostile_cases as hostile
from experiments.paper.e06_hostile_runs import tiny_scene
from experiments.publish import report, text
from experiments.runs import gate
from tests.hard.common import write_env

NAMES = hostile.HOSTILE_NAMES
IDS = [f"name{i}" for i in range(len(NAMES))]


# --------------------------------------------------------------------------- the text functions


@pytest.mark.parametrize("name", NAMES, ids=IDS)
def test_visible_leaves_nothing_a_terminal_interprets(name):
    out = text.visible(name)
    assert not hostile.terminal_problems(out) and "\n" not in out
    assert text.visible(out) == out  # idempotent: already visible text passes unchanged


def test_visible_shows_what_it_replaced():
    assert text.visible("a\x1b[31mb") == "a\\x1b[31mb"
    assert text.visible("x\ny\tz") == "x\\ny\\tz"
    assert text.visible("\u202eevil") == "\\u202eevil"
    assert text.visible(b"caf\xe9".decode("utf-8", "surrogateescape")) == "caf\\xe9"  # a file name's byte


def test_one_line_keeps_both_ends_of_a_long_line():
    line = text.one_line("file.toml: key = " + "9" * 10_000 + ": must be a number")
    assert len(line) < 700 and line.startswith("file.toml: key = ") and line.endswith(": must be a number")
    assert "characters left out" in line


@pytest.mark.parametrize("name", NAMES, ids=IDS)
def test_md_cell_is_one_cell_without_html(name):
    cell = text.md_cell(name)
    assert not hostile.markdown_problems(f"| {cell} | x |\n|---|---|\n| {cell} | y |")


# --------------------------------------------------------------------------- HTML


@pytest.fixture(scope="module")
def hostile_report(tmp_path_factory):
    """A report of rows carrying every hostile name in every field, with hostile paper sections."""
    out = tmp_path_factory.mktemp("hostile-report")
    section = report.Section(NAMES[0], [report.table(list(NAMES[:3]), [list(NAMES[i:i + 3]) for i in range(0, 12, 3)]),
                                        report.paragraph(NAMES[1]), report.bullets(list(NAMES)),
                                        report.figure(NAMES[4], NAMES[2]), report.figure("../../etc/x.png", "up")],
                             report.md_table(["name"], [[n] for n in NAMES]))
    legacy = {"title": NAMES[2], "html": NAMES[0] + "<script>alert(1)</script>", "markdown": NAMES[1], "figures": []}
    (out / report.SECTIONS).write_text(json.dumps({"title": NAMES[3], "subtitle": NAMES[5],
                                                   "sections": [vars(section), legacy]}))
    report.build(out, rows=hostile.hostile_rows())
    return out


def test_report_page_holds_no_markup_from_the_names(hostile_report):
    html = (hostile_report / "index.html").read_text()
    assert hostile.page_problems(html) == []
    # the names are there, as text: a parser gets each one back
    from html.parser import HTMLParser

    texts: list[str] = []

    class Collect(HTMLParser):
        def handle_data(self, data):
            texts.append(data)

    Collect().feed(html)
    body = "".join(texts)
    for name in NAMES:
        assert text.html_text(name)[:20] in body, name  # control characters shown as escapes


def test_page_check_catches_an_unescaped_page(tmp_path, monkeypatch):
    """Negative control: the same rows rendered with autoescape off fail the check."""
    import jinja2

    real = jinja2.Environment.__init__

    def no_escape(self, *a, **k):
        k["autoescape"] = False
        real(self, *a, **k)

    monkeypatch.setattr(jinja2.Environment, "__init__", no_escape)
    html = report.build(tmp_path, rows=hostile.hostile_rows()).read_text()
    problems = hostile.page_problems(html)
    assert any("onerror" in p for p in problems) and any("<svg>" in p for p in problems), problems


def test_report_sources_are_local_and_the_policy_allows_only_its_own_script_files(hostile_report):
    html = (hostile_report / "index.html").read_text()
    assert "http://" not in html.split("<body>")[0] and "https://" not in html.split("<body>")[0]
    assert 'src="javascript:' not in html and 'src="https://' not in html and 'src="../' not in html
    from html import unescape
    from html.parser import HTMLParser

    csp = unescape(html.split('http-equiv="Content-Security-Policy" content="', 1)[1].split('"', 1)[0])
    directives = {d.split()[0]: d.split()[1:] for d in csp.split(";") if d.strip()}
    # scripts: the report folder's files only (served: 'self'; opened from disk: file:), no inline, no eval
    assert directives["default-src"] == ["'none'"] and directives["script-src"] == ["'self'", "file:"]
    assert "unsafe-eval" not in csp and "unsafe-inline" not in " ".join(directives["script-src"])
    scripts: list[tuple[dict, str]] = []

    class Scripts(HTMLParser):
        inside = False

        def handle_starttag(self, tag, attrs):
            if tag == "script":
                scripts.append((dict(attrs), ""))
                self.inside = True

        def handle_endtag(self, tag):
            self.inside = self.inside and tag != "script"

        def handle_data(self, data):
            if self.inside:
                scripts[-1] = (scripts[-1][0], scripts[-1][1] + data)

    Scripts().feed(html)
    assert [(a.get("src"), body) for a, body in scripts] == [("viewer/viewer.js", "")]  # a file, nothing inline
    assert (hostile_report / "viewer" / "viewer.js").is_file()
    assert hostile.csp_problems(csp) == []
    for bad in ("script-src 'self' 'unsafe-eval'", "script-src 'self' 'unsafe-inline'", "script-src *",
                "script-src 'sha256-abc'", "script-src https://cdn.example"):  # controls
        assert hostile.csp_problems(csp.replace("script-src 'self' file:", bad)), bad


def test_legacy_html_sections_are_shown_as_text(hostile_report):
    html = (hostile_report / "index.html").read_text()
    assert "<script>alert(1)</script>" not in html and "&lt;script&gt;alert(1)" not in html  # html dropped
    assert html.count("<pre>") >= 1


def test_summary_markdown_is_escaped(hostile_report):
    md = (hostile_report / "summary.md").read_text()
    assert hostile.markdown_problems(md) == []


def test_report_opens_in_headless_chromium_and_runs_no_hostile_script(hostile_report, tmp_path):
    browser = next((shutil.which(b) for b in ("chromium", "chromium-browser", "google-chrome") if shutil.which(b)),
                   None)
    if browser is None:
        pytest.skip("no chromium (`make test` installs Debian's chromium where it can)")
    out = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--enable-logging=stderr", "--v=0",
                          f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=2000", "--dump-dom",
                          (hostile_report / "index.html").as_uri()], capture_output=True, text=True, timeout=120)
    assert "</table>" in out.stdout, out.stderr[-2000:]
    assert f'{hostile.PWNED}="1"' not in out.stdout  # no payload ran
    assert "<svg" not in out.stdout and "<img src=\"x\"" not in out.stdout
    blocked = [x for x in out.stderr.splitlines() if "Content Security Policy" in x]
    assert not blocked, blocked  # nothing even tried to run or load: the names never became markup


# --------------------------------------------------------------------------- JUnit and terminal


def test_junit_parses_whatever_the_names(tmp_path):
    results = [gate.GateResult(name, {"psnr": 20.0}, {"min_psnr": 30.0}, [f"psnr low for {name}"]) for name in NAMES]
    gate.write_junit(tmp_path / "g.xml", results)
    cases = ET.parse(tmp_path / "g.xml").getroot().findall("testsuite/testcase")
    assert [c.get("name") for c in cases] == [text.visible(n) for n in NAMES]
    assert all(c.find("failure") is not None for c in cases)


def test_tables_for_the_terminal_hold_no_control_characters():
    results = [gate.GateResult(name, {"psnr": None}, {"min_psnr": 30.0}, ["x"]) for name in NAMES]
    assert hostile.terminal_problems(gate.format_table(results)) == []
    assert hostile.terminal_problems(text.comparison_table([{"scene": n, "psnr": 1.0} for n in NAMES])) == []


@pytest.mark.parametrize("name", NAMES, ids=IDS)
def test_error_lines_name_hostile_files_safely(tmp_path, capsys, name):
    """A hostile file name (missing) and a hostile --set value: one line, exit 2, no control character."""
    code = cli.main(["render", str(tmp_path / f"{hostile.file_safe(name)}.toml")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and not hostile.terminal_problems(err.strip())
    scene = tiny_scene(tmp_path)
    safe = hostile.file_safe(name)
    for value in (f"camera.fov_deg={name}", f"environment.map={tmp_path / safe}.exr",
                  f"objects.0.shape={tmp_path / safe}.obj"):
        code = cli.main(["render", str(scene), "--set", value])
        err = capsys.readouterr().err
        assert code == 2 and len(err.strip().splitlines()) == 1 and not hostile.terminal_problems(err.strip()), err


@pytest.mark.gl
def test_warning_lines_carry_hostile_names_safely(tmp_path, capsys):
    """The teapot's unsimulated effects warning names the scene: one clean line per warning."""
    for name in NAMES[6:10]:
        scene = tiny_scene(tmp_path, name, shape="teapot")
        assert cli.main(["render", str(scene), "-o", str(tmp_path / "o.exr")]) == 0
        err = capsys.readouterr().err
        warnings_ = [x for x in err.splitlines() if x.startswith("warning:")]
        assert warnings_ and len(err.strip().splitlines()) == len(warnings_), err
        assert not hostile.terminal_problems(err), err


# --------------------------------------------------------------------------- end to end


@pytest.mark.gl
@pytest.mark.mitsuba
def test_sweep_with_hostile_scene_map_mesh_and_axis_values(tmp_path, monkeypatch, capsys):
    """A sweep whose scene name comes from --set, whose map and mesh files have hostile names and whose
    axis values are hostile names: the report page and summary hold them as text, the terminal is clean."""
    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    env = write_env(tmp_path / f"{hostile.file_safe(NAMES[2])}.exr", np.full((8, 16, 3), 0.5, np.float32))
    mesh = tmp_path / f"{hostile.file_safe(NAMES[0])}.obj"
    mesh.write_text(hostile.cube_obj(False))
    scene = tiny_scene(tmp_path, NAMES[6], env=str(env), shape=str(mesh))
    out = tmp_path / "sweep"
    code = cli.main(["sweep", str(scene), "--face-sizes", "8", "--lod-biases", "0", "--set", f"name={NAMES[1]}",
                     "--axis", f"name={NAMES[3].replace(',', ';')},{NAMES[13]}", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert hostile.terminal_problems(captured.out) == []
    html = (out / "index.html").read_text()
    assert hostile.page_problems(html) == []
    assert hostile.markdown_problems((out / "summary.md").read_text()) == []
    assert len([x for x in (out / "results.jsonl").read_text().splitlines() if x]) == 2
