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
  ctrl-click compares two rows (B = the second row's test radiance); a row without data says why.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from scenes.model.tonemap import to_uint8, tonemap

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
    done = subprocess.run(["node", str(DRIVER), str(path)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
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
