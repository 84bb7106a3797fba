"""Ctrl-C says what is true for the command that was interrupted: a sweep or the paper suite keeps its
finished rows (and names where), a render, compare or gate leaves only whole files and resumes nothing."""

from __future__ import annotations

import pytest

from experiments.cli import main as cli


def interrupted(*_args, **_kwargs):
    raise KeyboardInterrupt


@pytest.mark.parametrize("command, argv, says, never", [
    ("_cmd_sweep", ["sweep", "builtin:sphere-diffuse", "--out", "OUTDIR"], "kept in OUTDIR/results.jsonl", "whole"),
    ("_cmd_paper", ["paper", "--out", "PAPERDIR"], "kept in PAPERDIR/results.jsonl", "whole"),
    ("_cmd_render", ["render", "builtin:sphere-diffuse", "-o", "x.exr"], "whole or not at all", "rows"),
    ("_cmd_compare", ["compare", "builtin:sphere-diffuse"], "whole or not at all", "rows"),
    ("_cmd_gate", ["gate", "builtin:sphere-diffuse"], "no verdict", "rows"),
])
def test_interruption_says_what_is_kept(monkeypatch, capsys, command, argv, says, never):
    monkeypatch.setattr(cli, command, interrupted)  # looked up when the parser is built
    assert cli.main(argv) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: interrupted;")
    assert says in err[0] and never not in err[0]
