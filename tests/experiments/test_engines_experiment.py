"""E12's plumbing (experiments/paper/e12_engines.py) with stand-in engines, tiny and without a browser or bpy:
an engine that renders is scored and named with its version in its rows; an engine that is not installed
is left out with the reason its command gave, never silently; the progress bar advances as count_steps says.
The real engines' numbers are E12's own output (reports/paper); their conventions are tested in
tests/engines/."""

from __future__ import annotations

import json
import textwrap
from dataclasses import replace

import numpy as np
import pytest

from experiments.paper import e11_split_sum as e11
from experiments.paper import e12_engines as e12
from experiments.paper.context import Common, Context

#: an engine that writes a grey image of the sidecar's size and says who it is
GREY_ENGINE = textwrap.dedent("""
    import json, sys
    import numpy as np
    from scenes.storage import imageio
    args = dict(zip(sys.argv[1::2], sys.argv[2::2]))
    side = json.load(open(args["--sidecar"]))
    w, h = side["image"]["width"], side["image"]["height"]
    imageio.write_exr(args["--output"], np.full((h, w, 3), 0.3, np.float32))
    json.dump({"engine": "grey", "version": "1.2.3", "frame_ms": [4.0, 5.0, 6.0]}, open(args["--timings"], "w"))
    """)

TINY = e12.Settings(e11=replace(e11.QUICK, height=16, object_size=16, probes=("uffizi",), chain_size=8, frames=1,
                                subpixels=1, exact_samples=64, exact_lut=(16, 64), grid_spp=16),
                    probes=("uffizi",), diagnose=False)


@pytest.mark.mitsuba
@pytest.mark.slow
def test_a_rendering_engine_is_scored_and_a_missing_one_is_named_absent(tmp_path, monkeypatch):
    script = tmp_path / "grey_engine.py"
    script.write_text(GREY_ENGINE)
    templates = {"grey": f"{{python}} {script} --sidecar {{sidecar}} --output {{output}} --timings {{timings}}",
                 "gone": "/nonexistent/engine --sidecar {sidecar} --output {output}"}
    monkeypatch.setattr(e12, "ENGINES", {"grey": None, "gone": None})
    monkeypatch.setattr(e12, "ENGINE_NAMES", {"grey": "Grey", "gone": "Gone"})
    monkeypatch.setattr(e12, "TRUTH_OF", {"grey": "Mitsuba", "gone": "Mitsuba"})
    monkeypatch.setattr(e12, "engine_overrides", lambda engine: {
        "realtime.renderer": "command", "realtime.command.template": templates[engine]})
    steps = []
    ctx = Context(tmp_path / "out", Common(size=16, spp=16, frames=1), lambda: steps.append(1))
    section = e12.run(ctx, TINY)

    assert len(steps) == e12.count_steps(TINY)
    assert "Gone is absent from this run" in section.markdown and "'/nonexistent/engine' was not found" \
        in section.markdown
    rows = [json.loads(line) for line in (tmp_path / "out" / "results.jsonl").read_text().splitlines()]
    grey = [r for r in rows if r["techniques"].get("engine") == "grey"]
    assert len(grey) == 2  # the grid and the pawn
    assert all(r["gl_renderer"] == "grey 1.2.3" and r["realtime_ms"]["total"] == 5.0 for r in grey)
    assert all(r["psnr"] is not None and np.isfinite(r["psnr"]) for r in grey)
    cells = [c for b in section.blocks if b["kind"] == "table" for r in b["rows"] for c in r]
    assert "Grey (grey 1.2.3)" in cells  # the engine and its version in the table
    assert "the diagnosis finds" not in section.markdown  # not run: no table of it
