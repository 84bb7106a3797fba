"""The report's viewer (experiments/publish/viewer/viewer.js) in headless Chromium, from file:// and http://.

A four-row sweep at 32 x 32 (sphere-diffuse and sphere-phong, face sizes 8 and 16) is built by `iblcheck
sweep`; one diffuse row then loses its measured arrays and `iblcheck report` rebuilds the page, so it is a row
without viewer data. tests/experiments/report_driver.mjs drives the page through its UI (clicks, keys, mouse
drags and wheel) and returns what the page showed; every expectation is computed here from the row's own files
(measured.npz: float32 radiance and the display transform; reference.npz; results.jsonl), not from the viewer:
- no CSP violation, console error or failed request; control: an inline script inserted by the driver is
  refused and reported as a violation, so the listener and the policy are live;
- the pixel inspector shows, at the pixel under the cursor (placed from the geometry of a fitted, centred
  image), the float32 test radiance within float16 rounding and 4-digit printing, the reference, and A - B;
  controls: the transposed and the upside-down pixel are rejected by the same check;
- a screenshot at a chosen exposure equals srgb(reinhard(f16(x) * 2^stops)) (scenes.model.tonemap) at every
  pixel centre within 1 of 255; control: the same image at 0 stops is rejected;
- zoom keeps the pixel under the cursor; pan moves both side-by-side canvases alike; flip shows A then B;
  the swipe divider dragged to 30 % is a column of its colour at 30 % of the canvas (control: none in the
  flip screenshot); screenshots are not blank (control: a uniform picture is);
- the scene filter hides exactly the other scene's rows; a header click sorts by PSNR (results.jsonl);
  ctrl-click compares two rows (B = the second row's test radiance); a row without data says why;
- only the opened rows' data files (and their references) are requested, each once (control: the report
  holds a data file for a row that was not opened); opening the second row in the main view makes the
  inspector read its measured.npz (control: the first row's value is rejected); the second seed, the error
  map and the FLIP map are each drawn (not blank, unlike the test image);
- the fitted 32 x 32 image on the 448-pixel canvas (a zoom by 14) is made of uniform 14 x 14 blocks
  (nearest neighbour; control: the same grid shifted by 7 pixels is not); the swipe picture equals the
  flip A picture left of the divider and the flip B picture right of it (its 12-pixel handle left out);
- the driver's exit 3 (Chromium there but not starting) skips with the driver's line (control: exit 2 fails).
A small hand-written report (`synthetic`, arrays written here with numpy + zlib + base64, served over HTTP
with one file delayed) covers the data handling: a reference file's "test" never replaces the row's; a
second row of another size is refused in one line; the compare list puts the open row's scene first; of
two picks of the compared row the latest wins though the first arrives later; `f` does nothing while a
select has the focus (control: it flips outside one); a missing reference file opens the row without it and
says so; a row of display values ("display": "srgb") is drawn as round(255 srgb(clip(x))) with the exposure
control disabled and its values labelled display (control: its Reinhard picture is rejected); after ten
rows with ten references the viewer holds at most 8 of each and no pending data file object.
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest

from scenes.model.tonemap import srgb_encode, to_uint8, tonemap

REPO = Path(__file__).resolve().parents[2]
DRIVER = REPO / "tests" / "experiments" / "report_driver.mjs"
MODULES = REPO / "engines" / "web" / "node_modules"
SIZE = 32
STOPS = 1.5
PIXELS = [(16, 16), (3, 20), (25, 9), (11, 27)]  # (x, y): on the sphere, its rim and the background
TINY = ["camera.width=32", "camera.height=32", "reference.spp=16", "realtime.timing_frames=2",
        "realtime.warmup_frames=1"]
DIVIDER = (255, 0, 255)  # viewer.css: the swipe divider's line


def _chromium() -> str | None:
    return os.environ.get("IBLCHECK_CHROMIUM") or next(
        (p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)


def _browser_missing() -> str | None:
    if shutil.which("node") is None:
        return "node is not installed (Debian's nodejs; make setup installs it as root)"
    if _chromium() is None:
        return "no Chromium on PATH (Debian's chromium; make setup installs it as root)"
    if not (MODULES / "puppeteer-core" / "package.json").exists():
        return "engines/web/node_modules lacks puppeteer-core: run `npm ci --prefix engines/web` (make setup)"
    return None


pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.gl, pytest.mark.mitsuba,
              pytest.mark.skipif(_browser_missing() is not None, reason=str(_browser_missing()))]


def _cli(*args: str, cache: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(REPO), "IBLCHECK_CACHE": str(cache)}
    done = subprocess.run([sys.executable, "-m", "experiments.cli.main", *args], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> dict:
    """The report folder and its rows (results.jsonl), by scene, with one row stripped of its data."""
    out = tmp_path_factory.mktemp("viewer-report")
    cache = tmp_path_factory.getbasetemp() / "cache"
    sets = [a for kv in TINY for a in ("--set", kv)]
    _cli("sweep", "builtin:sphere-diffuse", "builtin:sphere-phong", "--face-sizes", "8,16", "--lod-biases", "0",
         "--exponents", "50", "--out", str(out), *sets, cache=cache)
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines() if line.strip()]
    phong = [r for r in rows if r["scene"] == "sphere-phong"]
    diffuse = [r for r in rows if r["scene"] == "sphere-diffuse"]
    assert len(phong) == 2 and len(diffuse) == 2
    (out / diffuse[1]["images"]["arrays"]).unlink()
    _cli("report", str(out), cache=cache)
    return {"dir": out, "rows": rows, "row": phong[0], "second": phong[1], "nodata": diffuse[1]}


def run_driver(path: Path, env: dict | None = None) -> dict:
    """The driver's JSON for the config at `path`; its exit 3 (no usable Chromium or packages) skips."""
    done = subprocess.run(["node", str(DRIVER), str(path)], capture_output=True, text=True, timeout=300,
                          env={**os.environ, **(env or {})})
    if done.returncode == 3:
        pytest.skip(done.stderr.strip().splitlines()[-1] if done.stderr.strip() else "driver exit 3")
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.fixture(scope="module", params=["file", "http"])
def driven(report, request, tmp_path_factory) -> dict:
    """What the driver saw, the page opened from disk or from a static server on 127.0.0.1."""
    shots = tmp_path_factory.mktemp(f"screenshots-{request.param}")
    cfg = {"report": str(report["dir"]), "http": request.param == "http", "out": str(shots),
           "row": report["row"]["id"], "second": report["second"]["id"], "nodata": report["nodata"]["id"],
           "width": SIZE, "height": SIZE, "pixels": PIXELS, "exposure": STOPS, "filter_scene": "sphere-phong",
           "sort_header": "PSNR dB"}
    path = shots / "config.json"
    path.write_text(json.dumps(cfg))
    result = run_driver(path)
    (shots / "driver.json").write_text(json.dumps(result, indent=1))
    print(f"{request.param}: open {result['timings']['open_ms']:.0f} ms, show a row "
          f"{result['timings']['show_row_ms']:.0f} ms; screenshots in {shots}")
    return result


# --------------------------------------------------------------------------- expectations, computed here


def arrays(report: dict, row: dict) -> dict:
    """A row's float32 radiance and display transform (measured.npz) and its reference (reference.npz)."""
    folder = report["dir"]
    with np.load(folder / row["images"]["arrays"]) as z:
        out = {"rgb": z["rgb"].astype(np.float32), "tonemap": json.loads(str(z["tonemap"]))}
    with np.load(folder / Path(row["images"]["arrays"]).parent.parent / "reference.npz") as z:
        out["reference"] = z["reference"].astype(np.float32)
    return out


def shown_matches(text: str, expected: np.ndarray) -> bool:
    """Does the inspector's text (numbers to 4 significant digits) show `expected` (float32), within float16
    rounding (half an ulp: 2^-11 relative above 2^-14, 2^-25 below) and the rounding of 4-digit printing?"""
    shown = np.array([float(v) for v in text.split()])
    expected = np.asarray(expected, np.float64).ravel()
    if shown.shape != expected.shape:
        return False
    mag = np.abs(expected)
    digits = 0.5 * 10.0 ** (np.floor(np.log10(np.maximum(mag, 1e-30))) - 3)
    tol = np.maximum(mag * 2.0**-11, 2.0**-25) + digits * 1.0001 + 1e-12
    return bool(np.all(np.abs(shown - expected) <= tol))


def test_shown_matches_rejects_a_wrong_value():
    assert shown_matches("0.6011 1.069", np.array([0.60107, 1.0691]))
    assert not shown_matches("0.6011 1.069", np.array([0.6031, 1.0691]))
    assert not shown_matches("0.6011", np.array([0.6011, 0.5]))


def picture(path: str) -> np.ndarray:
    import matplotlib.image  # deferred: matplotlib is heavy and only these tests read PNG screenshots

    return np.round(matplotlib.image.imread(path)[..., :3] * 255.0).astype(np.int32)


def not_blank(img: np.ndarray) -> bool:
    return float(img.reshape(-1, 3).std(axis=0).max()) > 5.0


def divider_columns(img: np.ndarray) -> np.ndarray:
    """Columns of which at least 90 % of the pixels have the divider's colour (within 8 of 255)."""
    hit = np.all(np.abs(img - np.array(DIVIDER)) <= 8, axis=-1)
    return np.flatnonzero(hit.mean(axis=0) >= 0.9)


def pixel_centres(img: np.ndarray, g: dict) -> np.ndarray:
    """The screenshot of the canvas (its border included) sampled at the centre of every image pixel of a
    fitted, centred SIZE x SIZE image: (SIZE, SIZE, 3)."""
    border = (img.shape[1] - g["cw"]) // 2
    s = min(g["cw"], g["ch"]) / SIZE
    tx, ty = (g["cw"] - s * SIZE) / 2, (g["ch"] - s * SIZE) / 2
    centres = (np.arange(SIZE) + 0.5) * s
    cols = np.floor(border + tx + centres).astype(int)
    rows = np.floor(border + ty + centres).astype(int)
    return img[np.ix_(rows, cols)]


# --------------------------------------------------------------------------- the tests


def test_page_runs_under_its_csp(driven):
    assert driven["scripts"] == ["viewer/viewer.js"]
    assert driven["violations"] == []
    # over HTTP, Chromium asks the server for /favicon.ico by itself (the page names no icon): not the page's
    icon = [b for b in driven["bad_responses"] if b.endswith("/favicon.ico")]
    assert [b for b in driven["bad_responses"] if b not in icon] == []
    before = driven["console"][:driven["console_before_control"]]
    errors = [m for m in before if m["type"] in ("error", "pageerror", "warning")]
    if icon:
        errors.remove({"type": "error", "text": "Failed to load resource: the server responded with a status of 404 "
                                                "(Not Found)"})
    assert errors == [], before
    assert driven["failed"] == []
    # control: an inline script is refused, and the refusal is seen by the listener the check relies on
    assert driven["inline_ran"] is False
    assert any(v["directive"].startswith("script-src") for v in driven["violations_after_inline"])


def test_inspector_shows_the_rows_linear_values(driven, report):
    data = arrays(report, report["row"])
    rgb, ref = data["rgb"], data["reference"]
    controls_rejected = 0
    for reading in driven["inspector"]:
        x, y = reading["at"]
        a = reading["canvas_a"]
        assert (int(a["x"]), int(a["y"])) == (x, y), a["text"]
        assert shown_matches(a["a"], rgb[y, x]), (a["text"], rgb[y, x])
        assert shown_matches(a["b"], ref[y, x]), (a["text"], ref[y, x])
        diff = rgb[y, x].astype(np.float16).astype(np.float64) - ref[y, x]
        shown_d = np.array([float(v) for v in a["d"].split()])
        assert np.allclose(shown_d, diff, rtol=5e-4, atol=1e-7), (a["text"], diff)
        # the other canvas, same pixel: the same reading (synchronised views)
        assert {k: reading["canvas_b"][k] for k in "xyabd"} == {k: a[k] for k in "xyabd"}
        # controls: the transposed and the upside-down pixel
        for cx, cy in ((y, x), (x, SIZE - 1 - y)):
            if (cx, cy) != (x, y) and not np.allclose(rgb[cy, cx], rgb[y, x], rtol=3e-3):
                assert not shown_matches(a["a"], rgb[cy, cx])
                controls_rejected += 1
    assert controls_rejected >= 3


def test_exposure_display_is_reinhard_then_srgb(driven, report):
    data = arrays(report, report["row"])
    tm = data["tonemap"]
    half = data["rgb"].astype(np.float16).astype(np.float32)
    img = pixel_centres(picture(driven["screenshots"]["exposure"]), driven["canvas_geometry"])

    def expected(stops: float) -> np.ndarray:
        return to_uint8(tonemap(half, tm["key"], tm["white"], tm["exposure"] + stops, tm["adapt_lum"])).astype(int)

    assert float(driven["exposure_range"]) == STOPS
    assert np.abs(img - expected(STOPS)).max() <= 1
    assert np.abs(img - expected(0.0)).max() > 8  # control: the exposure was applied


def test_zoom_keeps_the_pixel_under_the_cursor_and_pan_moves_both_views(driven):
    x, y = driven["zoom"]["before"]
    assert (int(driven["zoom"]["after"]["x"]), int(driven["zoom"]["after"]["y"])) == (x, y)
    side, zoomed = picture(driven["screenshots"]["side"]), picture(driven["screenshots"]["zoomed"])
    assert side.shape == zoomed.shape and np.abs(side - zoomed).mean() > 3
    pan_a, pan_b = driven["pan"]["a"], driven["pan"]["b"]
    assert (pan_a["x"], pan_a["y"]) == (pan_b["x"], pan_b["y"])
    # both canvases set to the test image after the zoom and pan draw the same picture, not the fitted one
    a, b = picture(driven["screenshots"]["panned_a"]), picture(driven["screenshots"]["panned_b"])
    assert np.array_equal(a, b)
    assert np.abs(a - picture(driven["screenshots"]["side_canvas_a"])).mean() > 3  # control: it did move


def test_flip_and_swipe(driven):
    assert (driven["flip_before"], driven["flip_after"]) == ("A", "B")
    a, b = picture(driven["screenshots"]["flip_a"]), picture(driven["screenshots"]["flip_b"])
    assert np.abs(a - b).max() > 20
    assert abs(driven["divider"] - 0.3) <= 1.0 / driven["canvas_geometry"]["cw"]
    swipe = picture(driven["screenshots"]["swipe"])
    cols = divider_columns(swipe)
    border = (swipe.shape[1] - driven["canvas_geometry"]["cw"]) // 2
    assert cols.size in (1, 2, 3), cols
    assert abs(cols.mean() + 0.5 - border - 0.3 * driven["canvas_geometry"]["cw"]) <= 1.5, cols
    assert divider_columns(a).size == 0  # control: no divider where none is drawn


def test_screenshots_are_not_blank(driven):
    for name, path in driven["screenshots"].items():
        assert not_blank(picture(path)), name
    assert not not_blank(np.full((20, 20, 3), 128))  # control


def test_filter_by_scene_and_sort_by_psnr(driven, report):
    hidden = {r["row"]: r["hidden"] for r in driven["filtered"]}
    assert hidden == {r["id"]: r["scene"] != "sphere-phong" for r in report["rows"]}
    assert driven["filter_count"] == "2 of 4 rows"
    psnr = {r["id"]: r["psnr"] for r in report["rows"]}
    assert driven["order_sorted"] == sorted(psnr, key=psnr.get)
    assert driven["order_sorted_desc"] == sorted(psnr, key=psnr.get, reverse=True)


def test_two_rows_compared(driven, report):
    assert (driven["compare"]["a"], driven["compare"]["b"]) == ("test", "other")
    x, y = PIXELS[0]
    shown = driven["compare"]["inspector"]
    assert shown_matches(shown["a"], arrays(report, report["row"])["rgb"][y, x])
    assert shown_matches(shown["b"], arrays(report, report["second"])["rgb"][y, x])
    assert not_blank(picture(driven["screenshots"]["compare"]))


def test_a_row_without_data_says_why(driven, report):
    text = driven["nodata_message"]
    assert text.startswith(report["nodata"]["id"]) and "no images" in text and "\n" not in text
    assert driven["message_after_open"] == ""


def test_page_opens_and_shows_a_row_quickly(driven):
    assert driven["timings"]["open_ms"] < 5000
    assert driven["timings"]["show_row_ms"] < 5000


def _data_file(path: Path) -> dict:
    """The object a viewer data file passes to window.iblcheckViewer.add(...)."""
    text = path.read_text().strip()
    head = "window.iblcheckViewer.add("
    assert text.startswith(head) and text.endswith(");"), path
    return json.loads(text[len(head):-2])


def test_only_the_opened_rows_data_is_requested(driven, report):
    viewer = report["dir"] / "viewer"
    opened = [report["row"]["id"], report["second"]["id"]]
    rows = sorted(r for r in driven["requests"] if r.startswith("viewer/rows/"))
    refs = sorted(r for r in driven["requests"] if r.startswith("viewer/refs/"))
    assert rows == sorted(f"viewer/rows/{rid}.js" for rid in opened)
    wanted = {f"viewer/refs/{_data_file(viewer / 'rows' / f'{rid}.js')['reference']}.js" for rid in opened}
    assert sorted(refs) == sorted(wanted)  # each once: a reference shared by both rows is loaded one time
    # control: the report has a data file for a row that was not opened, so loading all of them would show
    others = [p.name for p in (viewer / "rows").glob("*.js") if p.stem not in opened]
    assert others


def test_opening_another_row_switches_the_inspector(driven, report):
    x, y = PIXELS[0]
    second, first = arrays(report, report["second"]), arrays(report, report["row"])
    shown = driven["switched"]
    assert shown_matches(shown["a"], second["rgb"][y, x]), shown["text"]
    assert shown_matches(shown["b"], second["reference"][y, x]), shown["text"]
    assert not shown_matches(shown["a"], first["rgb"][y, x] * 1.01)  # control: a wrong value is rejected


@pytest.mark.parametrize("name", ["reference2", "error", "flip"])
def test_second_seed_and_maps_are_drawn(driven, name):
    img, test = picture(driven["screenshots"][f"source_{name}"]), picture(driven["screenshots"]["switched_test"])
    inside = img[1:-1, 1:-1]  # the canvas without its 1-pixel border, which alone would not look blank
    assert not_blank(inside)
    assert img.shape == test.shape and np.abs(img - test).mean() > 1.0
    assert not not_blank(np.full_like(inside, 30))  # control: the empty canvas's background is blank


def blocks_uniform(img: np.ndarray, start: int, s: int, n: int) -> bool:
    """Is img[start + s i : start + s (i + 1), start + s j : ...] one colour for every i, j < n?"""
    tiles = img[start:start + s * n, start:start + s * n].reshape(n, s, n, s, 3)
    return bool(np.all(tiles.max(axis=(1, 3)) == tiles.min(axis=(1, 3))))


def test_zoom_is_nearest_neighbour(driven):
    g = driven["canvas_geometry"]
    assert (g["cw"], g["ch"]) == (448, 448)  # a 32-pixel image fitted at 14 screen pixels per image pixel
    img = picture(driven["screenshots"]["side_canvas_a"])
    border = (img.shape[1] - g["cw"]) // 2
    assert blocks_uniform(img, border, 14, SIZE)
    # control: the same picture cut into a grid shifted by half a block straddles the pixels' edges
    assert not blocks_uniform(img, border + 7, 14, SIZE - 1)


def test_swipe_shows_a_left_and_b_right_of_the_divider(driven):
    g = driven["canvas_geometry"]
    a, b = picture(driven["screenshots"]["flip_a"]), picture(driven["screenshots"]["flip_b"])
    swipe = picture(driven["screenshots"]["swipe"])
    border = (swipe.shape[1] - g["cw"]) // 2
    x = border + round(driven["divider"] * g["cw"])
    left, right = slice(0, x - 6), slice(x + 6, None)  # the divider's 12-pixel handle left out
    assert np.array_equal(swipe[:, left], a[:, left])
    assert np.array_equal(swipe[:, right], b[:, right])
    # control: A and B differ on both sides, so the other picture would be rejected
    assert not np.array_equal(a[:, left], b[:, left]) and not np.array_equal(a[:, right], b[:, right])


def test_driver_exit_3_skips_the_test(tmp_path):
    cfg = tmp_path / "config.json"
    cfg.write_text(json.dumps({"report": str(tmp_path), "http": False, "out": str(tmp_path)}))
    with pytest.raises(pytest.skip.Exception) as skipped:
        run_driver(cfg, env={"IBLCHECK_CHROMIUM": "/bin/false"})  # executable, but not a browser
    assert "did not start headless" in str(skipped.value) and "\n" not in str(skipped.value)
    with pytest.raises(AssertionError):  # control: any other failure (exit 2: no config) fails
        run_driver(tmp_path / "missing.json")


# --------------------------------------------------------------------------- a hand-written report

SYN = 8  # the synthetic images' size
SYN_PIXEL = (2, 5)  # (x, y)
CSP = ("default-src 'none'; script-src 'self' file:; style-src 'self' 'unsafe-inline' file:; "
       "img-src 'self' data: file:; base-uri 'none'; form-action 'none'")
TONEMAP = {"key": 0.18, "white": 4.0, "exposure": 0.0, "adapt_lum": 0.2}


def _img(values: np.ndarray) -> dict:
    """The viewer's image format, written here independently: zlib of little-endian float16, base64."""
    raw = np.ascontiguousarray(values, dtype="<f2").tobytes()
    return {"channels": values.shape[-1], "dtype": "f16", "codec": "deflate",
            "data": base64.b64encode(zlib.compress(raw)).decode("ascii")}


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory) -> dict:
    """A report of hand-made rows (see the module docstring) and what the driver saw of it over HTTP."""
    out = tmp_path_factory.mktemp("synthetic")
    viewer = out / "viewer"
    (viewer / "rows").mkdir(parents=True)
    (viewer / "refs").mkdir()
    for name in ("viewer.js", "viewer.css"):
        shutil.copy(REPO / "experiments" / "publish" / "viewer" / name, viewer / name)
    rng = np.random.default_rng(7)
    images: dict[str, np.ndarray] = {}

    def write(folder: str, obj: dict) -> None:
        text = "window.iblcheckViewer.add(" + json.dumps(obj, ensure_ascii=True) + ");"
        (viewer / folder / f"{obj['id'].removeprefix('ref-')}.js").write_text(text)

    def ref(rid: str, decoy: bool = False) -> None:
        images[f"ref-{rid}"] = rng.uniform(0.0, 2.0, (SYN, SYN, 3)).astype(np.float32)
        imgs = {"reference": _img(images[f"ref-{rid}"])}
        if decoy:  # what a reference file may not contribute
            images[f"decoy-{rid}"] = rng.uniform(5.0, 9.0, (SYN, SYN, 3)).astype(np.float32)
            imgs |= {"test": _img(images[f"decoy-{rid}"]), "error": _img(np.ones((SYN, SYN, 1)))}
        write("refs", {"id": f"ref-{rid}", "width": SYN, "height": SYN, "images": imgs})

    table = []

    def row(rid: str, scene: str, ref_id: str, w: int = SYN, h: int = SYN, **extra) -> None:
        lo, hi = (-0.1, 1.3) if extra.get("display") else (0.0, 3.0)
        images[rid] = rng.uniform(lo, hi, (h, w, 3)).astype(np.float32)
        write("rows", {"id": rid, "label": rid, "width": w, "height": h, "tonemap": TONEMAP, "psnr": None,
                       "reference": ref_id, "images": {"test": _img(images[rid])}, **extra})
        table.append(f'<tr data-row="{rid}" data-scene="{scene}" data-technique="t" data-effects="diffuse" '
                     f'data-data="viewer/rows/{rid}.js"><td>{scene}</td><td>t</td><td>{rid}</td></tr>')

    ref("ra", decoy=True)
    row("beta-small", "beta", "ra", w=6)
    for rid in ("a-first", "a-slow", "a-fast"):
        row(rid, "alpha", "ra")
    row("a-noref", "alpha", "gone")
    row("a-display", "alpha", "ra", display="srgb")
    many = [f"m{i}" for i in range(10)]
    for i, rid in enumerate(many):
        ref(f"rm{i}")
        row(rid, "many", f"rm{i}")
    (out / "index.html").write_text(
        f'<!doctype html><html><head><meta charset="utf-8"><meta http-equiv="Content-Security-Policy" '
        f'content="{CSP}"><link rel="stylesheet" href="viewer/viewer.css"><title>synthetic</title></head><body>'
        f'<table id="rows" class="sortable"><thead><tr><th>scene</th><th>technique</th><th>row</th></tr></thead>'
        f'<tbody>{"".join(table)}</tbody></table><div id="viewer" data-rows="{len(table)}"></div>'
        f'<script src="viewer/viewer.js"></script></body></html>')
    cfg = {"synthetic": True, "report": str(out), "http": True, "out": str(out),
           "delay": {"/viewer/rows/a-slow.js": 1500}, "first": "a-first", "other_size": "beta-small",
           "slow": "a-slow", "fast": "a-fast", "noref": "a-noref", "display": "a-display", "many": many,
           "pixel": list(SYN_PIXEL), "size": SYN}
    (out / "config.json").write_text(json.dumps(cfg))
    result = run_driver(out / "config.json")
    (out / "driver.json").write_text(json.dumps(result, indent=1))
    return {"result": result, "images": images, "many": many}


def test_synthetic_page_has_no_errors(synthetic):
    r = synthetic["result"]
    assert [m for m in r["console"] if m["type"] == "pageerror"] == []
    assert r["violations"] == []


def test_a_reference_file_contributes_only_reference_images(synthetic):
    x, y = SYN_PIXEL
    im, shown = synthetic["images"], synthetic["result"]["first"]["inspector"]
    assert shown_matches(shown["a"], im["a-first"][y, x]), shown["text"]
    assert not shown_matches(shown["a"], im["decoy-ra"][y, x])  # control: the decoy's value is rejected
    assert shown_matches(shown["b"], im["ref-ra"][y, x]), shown["text"]


def test_compare_list_puts_the_open_rows_scene_first(synthetic):
    options = synthetic["result"]["first"]["compare_options"]
    same = ["a-slow", "a-fast", "a-noref", "a-display"]
    assert options == same + ["beta-small"] + synthetic["many"]
    # control: the table's own order (beta-small first) is not it
    assert options != ["beta-small"] + same + synthetic["many"]


def test_a_second_row_of_another_size_is_refused(synthetic):
    got = synthetic["result"]["other_size"]
    assert "6 x 8" in got["message"] and "8 x 8" in got["message"] and "\n" not in got["message"]
    assert (got["compare"], got["b"]) == ("", "reference")


def test_the_latest_compare_pick_wins(synthetic):
    x, y = SYN_PIXEL
    race, im = synthetic["result"]["race"], synthetic["images"]
    assert race["compare"] == "a-fast"
    assert shown_matches(race["inspector"]["b"], im["a-fast"][y, x]), race["inspector"]["text"]
    assert not shown_matches(race["inspector"]["b"], im["a-slow"][y, x])  # control


def test_f_key_is_ignored_in_a_select(synthetic):
    f = synthetic["result"]["f_key"]
    assert (f["before"], f["in_select"]) == ("AB", "AB")
    assert f["outside"] == "B"  # control: the same key outside a select flips


def test_a_missing_reference_opens_the_row_and_says_so(synthetic):
    x, y = SYN_PIXEL
    got = synthetic["result"]["noref"]
    assert "reference gone not shown" in got["message"] and "\n" not in got["message"]
    assert shown_matches(got["inspector"]["a"], synthetic["images"]["a-noref"][y, x])
    assert got["inspector"]["b"] == "-"


def test_display_rows_are_srgb_encoded_only(synthetic):
    got = synthetic["result"]["display"]
    assert got["exposure_disabled"] and got["range_disabled"]
    assert (got["inspector"]["kindA"], got["inspector"]["kindB"]) == ("display", "linear")
    assert "display" in got["inspector"]["text"]
    half = synthetic["images"]["a-display"].astype(np.float16).astype(np.float64)
    img = picture(synthetic["result"]["screenshots"]["display"])
    border = (img.shape[1] - got["geometry"]["cw"]) // 2
    s = got["geometry"]["cw"] // SYN
    centres = border + (np.arange(SYN) * s + s // 2)
    shown = img[np.ix_(centres, centres)]
    assert np.abs(shown - to_uint8(srgb_encode(half)).astype(int)).max() <= 1
    reinhard = to_uint8(tonemap(half, TONEMAP["key"], TONEMAP["white"], TONEMAP["exposure"], TONEMAP["adapt_lum"]))
    assert np.abs(shown - reinhard.astype(int)).max() > 8  # control: the radiance display is rejected


def test_the_viewer_holds_a_bounded_amount(synthetic):
    held = synthetic["result"]["held"]
    assert held == {"pending": 0, "rows": 8, "refs": 8}, held
    assert synthetic["result"]["many_message"] == ""
