"""The report viewer's data files (experiments/publish/viewer_data.py) against the row's own arrays.

Each file is decoded here as the browser does it, written independently of the code under test:
strip the one call `window.iblcheckViewer.add(...);`, json.loads, base64, zlib, little-endian float16
(or uint8), H x W x C with row 0 at the top. The decoded images must equal the arrays the row was
measured from within float16 rounding (a relative error of at most 2^-11 for normal halves, an
absolute 2^-25 below 2^-14), with values above 65504 stored as 65504 and counted. Controls: the same
check rejects the image read upside down or big-endian, a data file written without ASCII escaping,
and a page with an inline script or a policy allowing eval.
"""

from __future__ import annotations

import base64
import json
import zlib
from pathlib import Path

import numpy as np
import pytest

import scenes
from experiments.cli import main as cli
from experiments.measure import pair
from experiments.measure.results import ResultRow, store_in
from experiments.paper import e06_hostile_cases as hostile
from experiments.publish import images, report, viewer_data
from scenes.model.render import Render
from scenes.model.tonemap import adaptation_luminance

H, W = 20, 24
F16_MAX = 65504.0  # the largest finite IEEE 754 binary16 value: (2 - 2^-10) * 2^15
CALL = "window.iblcheckViewer.add("


# --------------------------------------------------------------------------- an independent decoder


def read_call(path: Path) -> dict:
    """The argument of the file's one `window.iblcheckViewer.add(...);` statement, parsed as JSON."""
    text = path.read_text(encoding="ascii")
    assert text.startswith(CALL) and text.endswith(");\n") and text.count(CALL) == 1, text[:80]
    return json.loads(text[len(CALL):-3])


def decode(img: dict, height: int, width: int, order: str = "<", flip_rows: bool = False) -> np.ndarray:
    """An image of a data file as the viewer decodes it. `order` and `flip_rows` plant the controls."""
    assert img["codec"] == "deflate" and img["dtype"] in ("f16", "u8")
    raw = zlib.decompress(base64.b64decode(img["data"], validate=True))
    dtype = np.dtype(f"{order}f2") if img["dtype"] == "f16" else np.dtype(np.uint8)
    out = np.frombuffer(raw, dtype).reshape(height, width, img["channels"]).astype(np.float64)
    out = out[::-1] if flip_rows else out
    return out[..., 0] if img["channels"] == 1 else out


def within_half_rounding(decoded: np.ndarray, want: np.ndarray) -> bool:
    """Whether `decoded` is `want` rounded to float16 (clamped at +-65504): round-to-nearest errs by at
    most half a unit in the last place, 2^-11 relative for normal halves, 2^-25 absolute for subnormals."""
    want = np.clip(np.asarray(want, np.float64), -F16_MAX, F16_MAX)
    bound = np.maximum(np.abs(want) * 2.0**-11, 2.0**-25)
    with np.errstate(invalid="ignore"):  # a control's decoding may hold NaN: it fails the comparison
        return decoded.shape == want.shape and bool(np.all(np.abs(decoded - want) <= bound))


# --------------------------------------------------------------------------- rows measured without rendering


@pytest.fixture(scope="module")
def scene():
    return scenes.load("builtin:sphere-phong")


def _render(rgb: np.ndarray, mask: np.ndarray, renderer: str) -> Render:
    return Render(rgb=rgb.astype(np.float32), mask=mask, timings={"filter": 1.0, "draw": 2.0, "total": 3.0},
                  meta={"renderer": renderer, "spp": 16, "face_size": 8})


def renders(seed: int = 7, sun: float = 0.0):
    """A test image, a reference and its second seed; with `sun`, a few pixels of that radiance."""
    rng = np.random.default_rng(seed)
    truth = rng.uniform(0.0, 3.0, size=(H, W, 3)) * np.linspace(0.01, 1, H)[:, None, None]  # rows differ
    yy, xx = np.mgrid[:H, :W]
    disc = (yy - H / 2) ** 2 + (xx - W / 2) ** 2 < (0.45 * H) ** 2
    test = truth * 1.05 + 0.02
    ref = truth + rng.normal(0, 0.05, truth.shape).clip(-0.01)
    if sun:
        test[3, 4], ref[5, 6, 1] = sun, sun
    return (_render(test, disc, "realtime"), _render(ref, disc, "reference"),
            _render(truth + 0.01, disc, "reference"))


def make_row(root: Path, scene, rid: str, name: str = "sphere", seed: int = 7, sun: float = 0.0, ref_folder="r1",
             keep_reference: bool = True) -> tuple[ResultRow, tuple]:
    test, ref, ref2 = renders(seed, sun)
    m = pair.measure_pair(test, ref, scene, second_reference=ref2)
    pics = images.save_comparison(root, root / "images" / ref_folder / rid, m, test,
                                  ref if keep_reference else None, ref2, images.display_tonemap(scene))
    techniques = {"diffuse": "sh", "glossy": "box", "lod_bias": 0.0, "sh_order": 2, "lod_mapping": "paper",
                  "sh_window": "none"}
    row = ResultRow(id=rid, spec="builtin:sphere-phong", overrides={}, scene=name, techniques=techniques,
                    materials=[{"type": "phong", "exponent": 50.0, "f0": 0.04}],
                    env="builtin:sky", effects=["diffuse", "glossy"], unsimulated_effects=[], width=W, height=H,
                    face_size=8, psnr=m.psnr, ssim=m.ssim, flip=m.flip, rel_mse=m.rel_mse,
                    noise_floor_psnr=m.noise_floor_psnr, at_noise_floor=False, pixels=m.pixels,
                    realtime_ms={"filter": 1.0, "draw": 2.0, "total": 3.0}, reference_id=ref_folder, images=pics)
    return row, (test, ref, ref2, m)


def build(root: Path, rows: list[ResultRow]) -> str:
    return report.build(root, rows=rows).read_text()


def test_data_files_decode_to_the_rows_arrays(tmp_path, scene):
    row, (test, ref, ref2, m) = make_row(tmp_path, scene, "row1")
    html = build(tmp_path, [row])
    data = read_call(tmp_path / "viewer" / "rows" / "row1.js")
    assert (data["id"], data["width"], data["height"], data["psnr"]) == ("row1", W, H, row.psnr)
    assert data["label"] == report.label(row)
    got = {k: decode(v, H, W) for k, v in data["images"].items()}
    with np.load(tmp_path / row.images[images.ARRAYS]) as z:  # what the row kept, read directly
        kept_rgb = z["rgb"]
    assert within_half_rounding(got["test"], kept_rgb) and within_half_rounding(got["test"], test.rgb)
    assert within_half_rounding(got["error"], m.error_map) and within_half_rounding(got["flip"], m.flip_map)
    np.testing.assert_array_equal(got["mask"], m.mask.astype(float))
    assert data["images"]["test"]["clamped"] == 0
    # the display transform: the scene's Reinhard and the environment's log-average luminance, recomputed
    tm = scene.tonemap
    assert data["tonemap"] == pytest.approx({"key": tm.key, "white": tm.white, "exposure": tm.exposure,
                                             "adapt_lum": adaptation_luminance(scene.environment.radiance())})
    refs = read_call(tmp_path / "viewer" / "refs" / f"{data['reference']}.js")
    assert refs["id"] == f"ref-{data['reference']}" and (refs["width"], refs["height"]) == (W, H)
    assert within_half_rounding(decode(refs["images"]["reference"], H, W), ref.rgb)
    assert within_half_rounding(decode(refs["images"]["reference2"], H, W), ref2.rgb)
    # the page points at the file from the row, with the row's scene, technique and effects
    assert f'data-row="row1" data-scene="sphere" data-technique="{row.technique_label}" ' \
           f'data-effects="diffuse glossy" data-data="viewer/rows/row1.js"' in html
    assert '<div id="viewer" data-rows="1"></div>' in html


def test_the_decoding_check_rejects_a_wrong_row_order_or_byte_order(tmp_path, scene):
    """Controls: the same comparison fails for the image read upside down or as big-endian halves."""
    row, (test, *_) = make_row(tmp_path, scene, "row1")
    build(tmp_path, [row])
    img = read_call(tmp_path / "viewer" / "rows" / "row1.js")["images"]["test"]
    assert within_half_rounding(decode(img, H, W), test.rgb)
    assert not within_half_rounding(decode(img, H, W, flip_rows=True), test.rgb)
    assert not within_half_rounding(decode(img, H, W, order=">"), test.rgb)


def test_radiance_above_the_largest_half_is_clamped_and_counted(tmp_path, scene):
    row, (test, ref, _, _) = make_row(tmp_path, scene, "sun", sun=1e6)
    build(tmp_path, [row])
    data = read_call(tmp_path / "viewer" / "rows" / "sun.js")
    got = decode(data["images"]["test"], H, W)
    assert data["images"]["test"]["clamped"] == int((test.rgb > F16_MAX).sum()) == 3  # one pixel, three channels
    assert np.isfinite(got).all() and (got[3, 4] == F16_MAX).all()
    refs = read_call(tmp_path / "viewer" / "refs" / f"{data['reference']}.js")["images"]
    assert refs["reference"]["clamped"] == 1 and refs["reference2"]["clamped"] == 0
    assert decode(refs["reference"], H, W)[5, 6, 1] == F16_MAX


def test_rows_of_one_reference_share_its_file_and_rows_without_data_say_why(tmp_path, scene):
    a, _ = make_row(tmp_path, scene, "a")
    b, _ = make_row(tmp_path, scene, "b", seed=8)
    old, _ = make_row(tmp_path, scene, "old", ref_folder="r2", keep_reference=False)
    bare = ResultRow(**{**a.__dict__, "id": "bare", "images": {}})
    html = build(tmp_path, [a, b, old, bare])
    ra, rb = (read_call(tmp_path / "viewer" / "rows" / f"{x}.js") for x in ("a", "b"))
    assert ra["reference"] == rb["reference"] == "r1"
    assert sorted(p.name for p in (tmp_path / "viewer" / "refs").iterdir()) == ["r1.js"]
    assert read_call(tmp_path / "viewer" / "rows" / "old.js")["reference"] is None  # shown without a reference
    line = next(x for x in html.splitlines() if 'data-row="bare"' in x)
    assert "data-data" not in line and 'data-why="written before rows kept their arrays' in line


def test_a_measured_npz_from_before_the_viewer_still_opens(tmp_path, scene):
    """A row kept before the FLIP map and the display transform were: its file has what exists."""
    row, _ = make_row(tmp_path, scene, "legacy")
    path = tmp_path / row.images[images.ARRAYS]
    with np.load(path) as z:
        arrays = {k: z[k] for k in images.MEASURED_ARRAYS}
    np.savez(path, **arrays)
    build(tmp_path, [row])
    data = read_call(tmp_path / "viewer" / "rows" / "legacy.js")
    assert data["tonemap"] is None and set(data["images"]) == {"test", "error", "mask"}


HOSTILE_LABELS = ['say "hi"\' and \\ back', "</script><script>alert(1)</script>", "line\u2028sep\u2029para",
                  "<!-- <script>", "\x00\x1b[31m\ud800", *hostile.HOSTILE_NAMES]


def breaks_out(text: str) -> list[str]:
    """What in a data file could end its JSON string, its statement or an enclosing <script>: a
    character outside ASCII (U+2028/U+2029 end a line in older JavaScript), '</' or '<!--'."""
    problems = [f"U+{ord(c):04X}" for c in sorted(set(text)) if ord(c) > 126 or (ord(c) < 32 and c != "\n")]
    return problems + [s for s in ("</", "<!--") if s in text]


@pytest.mark.parametrize("name", HOSTILE_LABELS, ids=[f"label{i}" for i in range(len(HOSTILE_LABELS))])
def test_a_hostile_label_stays_inside_its_json_string(tmp_path, scene, name):
    row, _ = make_row(tmp_path, scene, "x", name=name)
    build(tmp_path, [row])
    path = tmp_path / "viewer" / "rows" / "x.js"
    text = path.read_bytes().decode("ascii")
    assert breaks_out(text) == []
    data = read_call(path)
    assert data["label"] == report.label(row) and name in data["label"]  # the name itself, round-tripped
    assert set(data) == {"id", "label", "width", "height", "tonemap", "psnr", "reference", "images"}


def test_the_break_out_check_catches_unescaped_json():
    """Control: json.dumps without ensure_ascii, as the file would be without the escaping, is caught."""
    for name in HOSTILE_LABELS[1:3]:
        assert breaks_out(CALL + json.dumps({"label": name}, ensure_ascii=False) + ");\n")
        assert breaks_out(viewer_data.statement({"label": name})) == []


def test_a_hostile_row_id_becomes_a_safe_file_name(tmp_path, scene):
    row, _ = make_row(tmp_path, scene, "plain")
    row = ResultRow(**{**row.__dict__, "id": "../../x\"'<script>"})
    html = build(tmp_path, [row])
    files = [p.name for p in (tmp_path / "viewer" / "rows").iterdir()]
    assert len(files) == 1 and files[0].startswith("h") and files[0].endswith(".js")
    assert read_call(tmp_path / "viewer" / "rows" / files[0])["id"] == row.id
    assert hostile.page_problems(html) == []


# --------------------------------------------------------------------------- the page


def test_the_page_has_no_inline_script_and_its_policy_no_eval(tmp_path, scene):
    row, _ = make_row(tmp_path, scene, "row1")
    html = build(tmp_path, [row])
    assert hostile.page_problems(html) == []
    assert "<script>" not in html and '<script src="viewer/viewer.js"></script>' in html
    assert "unsafe-eval" not in html and "sha256-" not in html
    assert (tmp_path / "viewer" / "viewer.js").read_bytes() == \
        (Path(viewer_data.__file__).parent / "viewer" / "viewer.js").read_bytes()
    # controls: an inline script, a policy allowing eval or inline script, a data file from elsewhere
    assert hostile.page_problems(html.replace("</body>", "<script>sort()</script></body>"))
    assert hostile.page_problems(html.replace("script-src &#39;self&#39;", "script-src &#39;unsafe-eval&#39;"))
    assert hostile.page_problems(html.replace("script-src &#39;self&#39;", "script-src &#39;unsafe-inline&#39;"))
    assert hostile.page_problems(html.replace('data-data="viewer/', 'data-data="https://x.org/'))
    assert hostile.page_problems(html.replace('src="viewer/viewer.js"', 'src="../viewer.js"'))


def _stamps(folder: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(folder)): (p.stat().st_ino, p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_rebuild_rewrites_only_what_changed(tmp_path, scene):
    rows = [make_row(tmp_path, scene, f"row{i}", seed=i)[0] for i in range(3)]
    build(tmp_path, rows)
    before = _stamps(tmp_path / "viewer")
    assert len([k for k in before if k.startswith("rows/")]) == 3
    build(tmp_path, rows)
    assert _stamps(tmp_path / "viewer") == before  # nothing rewritten (a rename would change the inode)
    # control: a changed label rewrites that row's file alone; a row left out loses its file
    rows[1] = ResultRow(**{**rows[1].__dict__, "scene": "renamed"})
    build(tmp_path, rows[:2])
    after = _stamps(tmp_path / "viewer")
    changed = {k for k in before if k in after and after[k] != before[k]}
    assert changed == {"rows/row1.js", "data.json"} and "rows/row2.js" not in after
    assert read_call(tmp_path / "viewer" / "rows" / "row1.js")["label"].startswith("renamed:")


# --------------------------------------------------------------------------- compare and gate --report


TINY = ["--set", "camera.width=24", "--set", "camera.height=24", "--set", "reference.spp=16",
        "--set", "realtime.timing_frames=2", "--set", "realtime.warmup_frames=1"]


@pytest.mark.gl
@pytest.mark.mitsuba
def test_compare_and_gate_write_a_report_of_their_rows(tmp_path, monkeypatch, capsys):
    """compare --report and gate --report: index.html with their rows; the data files hold the
    real-time image kept in measured.npz and the cached Mitsuba reference (and second seed)."""
    import groundtruth
    from experiments.measure import comparison

    monkeypatch.setenv("IBLCHECK_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "report"
    assert cli.main(["compare", "builtin:sphere-phong", *TINY, "--report", str(out)]) == 0, capsys.readouterr().err
    assert cli.main(["gate", "builtin:sphere-diffuse", "builtin:sphere-phong", *TINY, "--min-psnr", "1",
                     "--report", str(out)]) == 0, capsys.readouterr().err
    rows = store_in(out).read()
    assert sorted(r.scene for r in rows) == ["sphere-diffuse", "sphere-phong"]  # the same scene once
    html = (out / "index.html").read_text()
    assert hostile.page_problems(html) == [] and html.count("data-data=") == 2
    for r in rows:
        assert f'data-row="{r.id}"' in html
        data = read_call(out / "viewer" / "rows" / f"{r.id}.js")
        with np.load(out / r.images[images.ARRAYS]) as z:
            assert within_half_rounding(decode(data["images"]["test"], 24, 24), z["rgb"])
        sc = scenes.load(r.spec).with_overrides({k: v for k, v in (s.split("=") for s in TINY[1::2])})
        ref = groundtruth.render(sc)
        assert ref.meta["cache"] == "hit"  # the reference the row was measured against, from the cache
        refs = read_call(out / "viewer" / "refs" / f"{data['reference']}.js")["images"]
        assert within_half_rounding(decode(refs["reference"], 24, 24), ref.rgb)
        assert within_half_rounding(decode(refs["reference2"], 24, 24), comparison.second_reference(ref, sc).rgb)
    # `iblcheck report DIR` rebuilds the page (with its default title) without rewriting a data file
    before = _stamps(out / "viewer")
    assert cli.main(["report", str(out)]) == 0
    assert _stamps(out / "viewer") == before
    assert (out / "index.html").read_text() == html.replace("iblcheck gate", "iblcheck sweep")
