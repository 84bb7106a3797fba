#!/usr/bin/env node
// Drives an iblcheck report's viewer (experiments/publish/viewer/viewer.js) in headless Chromium for
// tests/experiments/test_report_viewer_browser.py, and prints what it saw as one JSON object on stdout.
//   node tests/experiments/report_driver.mjs CONFIG.json
// CONFIG: {"report": DIR, "http": bool (serve DIR from a static server on 127.0.0.1, else open file://),
//          "out": DIR (screenshots), "row": RID, "second": RID, "nodata": RID | null, "width": W, "height": H,
//          "pixels": [[x, y], ...], "exposure": stops, "filter_scene": NAME, "sort_header": TEXT}
//   or, for a small hand-written report (test_report_viewer_browser.py `synthetic`):
//         {"synthetic": true, "report": DIR, "http": true, "out": DIR, "delay": {"/viewer/rows/RID.js": ms},
//          "first": RID, "other_size": RID, "slow": RID, "fast": RID, "noref": RID, "display": RID,
//          "many": [RID, ...], "pixel": [x, y]}
// Everything the page does is through its UI: clicks, keys, mouse drags and wheel, as a user would; the
// pixel under the cursor is found from the geometry of a fitted, centred image, not from the viewer's state.
// Every request the page makes is listed in the result (`requests`, paths relative to the report).
// Exit 0 with the JSON; 3 and one `error:` line when Chromium or puppeteer-core is missing or Chromium
// does not start; 2 on a failure.
import { accessSync, constants, existsSync, readFileSync } from "node:fs";
import { readFile } from "node:fs/promises";
import { createServer } from "node:http";
import { delimiter, dirname, extname, join, resolve, sep } from "node:path";
import { fileURLToPath, pathToFileURL } from "node:url";

const REPO = resolve(dirname(fileURLToPath(import.meta.url)), "..", "..");
const MODULES = join(REPO, "engines", "web", "node_modules");

class Missing extends Error {}

function chromium() {
  const ok = (p) => { try { accessSync(p, constants.X_OK); return true; } catch { return false; } };
  if (process.env.IBLCHECK_CHROMIUM) {
    if (!ok(process.env.IBLCHECK_CHROMIUM)) throw new Missing(`IBLCHECK_CHROMIUM=${process.env.IBLCHECK_CHROMIUM} is not executable`);
    return process.env.IBLCHECK_CHROMIUM;
  }
  for (const dir of (process.env.PATH ?? "").split(delimiter)) {
    for (const name of ["chromium", "chromium-browser", "google-chrome"]) if (dir && ok(join(dir, name))) return join(dir, name);
  }
  throw new Missing("no Chromium on PATH (chromium, chromium-browser, google-chrome) or IBLCHECK_CHROMIUM");
}

const TYPES = { ".html": "text/html; charset=utf-8", ".js": "text/javascript", ".css": "text/css", ".png": "image/png" };

/** A read-only static server of `root` on a free port of 127.0.0.1. */
function serve(root, delay = {}) {
  root = resolve(root);
  const server = createServer(async (req, res) => {
    const rel = decodeURIComponent(new URL(req.url, "http://127.0.0.1").pathname);
    if (delay[rel]) await sleep(delay[rel]); // a slow file, to race two requests
    const file = resolve(root, "." + sep + rel);
    try {
      if (req.method !== "GET" || !(file === root || file.startsWith(root + sep))) throw new Error("not served");
      const body = await readFile(file);
      res.writeHead(200, { "content-type": TYPES[extname(file)] ?? "application/octet-stream" });
      res.end(body);
    } catch {
      res.writeHead(404, { "content-type": "text/plain" });
      res.end("not found");
    }
  });
  return new Promise((ok) => server.listen(0, "127.0.0.1", () => ok({ server, url: `http://127.0.0.1:${server.address().port}` })));
}

const sleep = (ms) => new Promise((ok) => setTimeout(ok, ms));

async function main() {
  const cfg = JSON.parse(readFileSync(process.argv[2], "utf-8"));
  const exe = chromium();
  const entry = join(MODULES, "puppeteer-core", "lib", "esm", "puppeteer", "puppeteer-core.js");
  if (!existsSync(entry)) throw new Missing(`puppeteer-core is not installed in ${MODULES}; run \`npm ci --prefix engines/web\``);
  // deferred: puppeteer-core lives in engines/web/node_modules, whose absence was just reported
  const { default: puppeteer } = await import(pathToFileURL(entry).href);
  const result = { console: [], violations: [], failed: [], screenshots: {}, inspector: [], timings: {} };
  let server = null;
  let url = pathToFileURL(join(resolve(cfg.report), "index.html")).href;
  if (cfg.http) {
    const s = await serve(cfg.report, cfg.delay);
    server = s.server;
    url = `${s.url}/index.html`;
  }
  result.url = url;
  const args = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-dev-shm-usage", "--no-first-run",
    "--no-default-browser-check", "--disable-extensions", "--force-color-profile=srgb", "--hide-scrollbars"];
  if (process.getuid?.() === 0) args.push("--no-sandbox");
  let browser;
  try {
    browser = await puppeteer.launch({ executablePath: exe, headless: true, args, timeout: 120000 });
  } catch (e) {
    throw new Missing(`${exe} did not start headless: ${String(e.message).split("\n")[0]}`);
  }
  try {
    const page = await browser.newPage();
    await page.setViewport({ width: 1400, height: 1000, deviceScaleFactor: 1 });
    page.on("console", (m) => result.console.push({ type: m.type(), text: m.text() }));
    page.on("pageerror", (e) => result.console.push({ type: "pageerror", text: String(e.message) }));
    result.requests = [];
    page.on("request", (r) => {
      const u = r.url(), base = url.slice(0, url.lastIndexOf("/") + 1);
      result.requests.push(u.startsWith(base) ? u.slice(base.length) : u);
    });
    page.on("requestfailed", (r) => result.failed.push(`${r.url()}: ${r.failure()?.errorText}`));
    result.bad_responses = [];
    page.on("response", (r) => { if (r.status() >= 400) result.bad_responses.push(`${r.status()} ${r.url()}`); });
    await page.evaluateOnNewDocument(() => {
      window.__violations = [];
      document.addEventListener("securitypolicyviolation", (e) => {
        window.__violations.push({ directive: e.violatedDirective, blocked: e.blockedURI, sample: e.sample });
      });
    });

    if (cfg.synthetic) {
      await synthetic(page, cfg, result);
      result.violations = await page.evaluate(() => window.__violations);
      await emit(result);
      return;
    }
    // open the page
    let t0 = performance.now();
    await page.goto(url, { waitUntil: "load" });
    await page.waitForFunction(() => document.documentElement.dataset.viewerReady === "true", { timeout: 30000 });
    result.timings.open_ms = performance.now() - t0;
    result.timings.page_ready_ms = await page.evaluate(() => performance.now());
    result.scripts = await page.evaluate(() => Array.from(document.scripts).map((s) => s.getAttribute("src")));

    // sorting: click a header of #rows, read the row order
    const rowOrder = () => page.$$eval("#rows tbody tr", (trs) => trs.map((tr) => tr.dataset.row));
    result.order_before = await rowOrder();
    await page.evaluate((text) => {
      const th = Array.from(document.querySelectorAll("#rows thead th")).find((h) => h.textContent.trim() === text);
      th.click();
    }, cfg.sort_header);
    result.order_sorted = await rowOrder();
    await page.evaluate((text) => {
      Array.from(document.querySelectorAll("#rows thead th")).find((h) => h.textContent.trim() === text).click();
    }, cfg.sort_header);
    result.order_sorted_desc = await rowOrder();

    // filtering by scene
    await page.select("#filter-scene", cfg.filter_scene);
    result.filtered = await page.$$eval("#rows tbody tr", (trs) => trs.map((tr) => ({ row: tr.dataset.row, scene: tr.dataset.scene, hidden: tr.hidden || getComputedStyle(tr).display === "none" })));
    result.filter_count = await page.$eval("#filter-count", (e) => e.textContent);
    await page.select("#filter-scene", "");

    // a row without data: one line in #viewer-message
    if (cfg.nodata) {
      await page.click(`#rows tr[data-row="${cfg.nodata}"] td`);
      await page.waitForFunction(() => document.getElementById("viewer-message").textContent.length > 0);
      result.nodata_message = await page.$eval("#viewer-message", (e) => e.textContent);
    }

    // open a row
    t0 = performance.now();
    await page.click(`#rows tr[data-row="${cfg.row}"] td`);
    await page.waitForFunction((id) => document.getElementById("viewer").dataset.open === id, { timeout: 30000 }, cfg.row);
    result.timings.show_row_ms = performance.now() - t0;
    result.timings.viewer_open_ms = Number(await page.$eval("#viewer", (e) => e.dataset.openMs));
    result.message_after_open = await page.$eval("#viewer-message", (e) => e.textContent);

    const geometry = (id) => page.$eval(id, (c) => {
      const r = c.getBoundingClientRect();
      return { left: r.left + c.clientLeft, top: r.top + c.clientTop, cw: c.width, ch: c.height, sx: c.clientWidth / c.width, sy: c.clientHeight / c.height };
    });
    // the client position of image pixel (x, y)'s centre in a fitted, centred image
    const where = (g, x, y) => {
      const s = Math.min(g.cw / cfg.width, g.ch / cfg.height);
      const tx = (g.cw - s * cfg.width) / 2, ty = (g.ch - s * cfg.height) / 2;
      return [g.left + (tx + (x + 0.5) * s) * g.sx, g.top + (ty + (y + 0.5) * s) * g.sy];
    };
    const readInspector = () => page.$eval("#inspector", (e) => ({ ...e.dataset, text: e.textContent }));
    const shoot = async (name, selector) => {
      const path = join(cfg.out, `${name}.png`);
      await (await page.$(selector)).screenshot({ path });
      result.screenshots[name] = path;
    };

    await shoot("side", "#viewer-panes");
    await shoot("side_canvas_a", "#canvas-a");
    let ga = await geometry("#canvas-a");
    const gb = await geometry("#canvas-b");
    for (const [x, y] of cfg.pixels) {
      await page.mouse.move(...where(ga, x, y));
      const a = await readInspector();
      await page.mouse.move(...where(gb, x, y));
      const b = await readInspector();
      result.inspector.push({ at: [x, y], canvas_a: a, canvas_b: b });
    }

    // zoom about the cursor: the pixel under it stays; then pan by a drag: both canvases follow
    const [px, py] = cfg.pixels[0];
    const at = where(ga, px, py);
    await page.mouse.move(...at);
    await page.mouse.wheel({ deltaY: -600 });
    await sleep(50);
    result.zoom = { before: cfg.pixels[0], after: await readInspector() };
    await shoot("zoomed", "#viewer-panes");
    await page.mouse.move(at[0] + 3, at[1] + 3);
    await page.mouse.down();
    await page.mouse.move(at[0] + 60, at[1] + 40, { steps: 5 });
    await page.mouse.up();
    await page.mouse.move(ga.left + 100, ga.top + 120);
    const panA = await readInspector();
    await page.mouse.move(gb.left + 100, gb.top + 120);
    const panB = await readInspector();
    result.pan = { a: panA, b: panB };
    // both canvases showing the test image after the zoom and pan: the same picture if the views are one
    await page.select("#source-b", "test");
    await page.mouse.move(0, 0);
    await shoot("panned_a", "#canvas-a");
    await shoot("panned_b", "#canvas-b");
    await page.select("#source-b", "reference");
    await page.click("#reset-view");

    // flip: the mode button, then the key f shows B
    await page.click("#mode-flip");
    await page.mouse.move(0, 0);
    result.flip_before = await page.$eval("#viewer-panes", (e) => e.dataset.shown);
    await shoot("flip_a", "#canvas-a");
    await page.keyboard.press("f");
    result.flip_after = await page.$eval("#viewer-panes", (e) => e.dataset.shown);
    await shoot("flip_b", "#canvas-a");

    // swipe: drag the divider to 30 % of the canvas
    await page.click("#mode-swipe");
    ga = await geometry("#canvas-a");
    const d = await page.$eval("#swipe-divider", (e) => { const r = e.getBoundingClientRect(); return [r.left + r.width / 2, r.top + r.height / 2]; });
    await page.mouse.move(...d);
    await page.mouse.down();
    const target = ga.left + 0.3 * ga.cw * ga.sx;
    await page.mouse.move(target, d[1], { steps: 8 });
    await page.mouse.up();
    await page.mouse.move(0, 0);
    result.divider = Number(await page.$eval("#swipe-divider", (e) => e.dataset.position));
    await shoot("swipe", "#canvas-a");

    // exposure: typed into the stops box, in side-by-side mode
    await page.click("#mode-side");
    await page.click("#exposure", { clickCount: 3 });
    await page.keyboard.type(String(cfg.exposure));
    await page.keyboard.press("Tab");
    result.exposure_range = await page.$eval("#exposure-range", (e) => e.value);
    await page.mouse.move(0, 0);
    await shoot("exposure", "#canvas-a");
    result.canvas_geometry = await geometry("#canvas-a");

    // compare two rows: ctrl-click a second row; B is its test image
    if (cfg.second) {
      await page.keyboard.down("Control");
      await page.click(`#rows tr[data-row="${cfg.second}"] td`);
      await page.keyboard.up("Control");
      await page.waitForFunction((id) => document.getElementById("compare").value === id, { timeout: 30000 }, cfg.second);
      result.compare = { a: await page.$eval("#source-a", (e) => e.value), b: await page.$eval("#source-b", (e) => e.value) };
      ga = await geometry("#canvas-a");
      await page.mouse.move(...where(ga, px, py));
      result.compare.inspector = await readInspector();
      await shoot("compare", "#viewer-panes");
    }

    // switch rows: open the second row in the main view; the inspector then reads its values
    if (cfg.second) {
      await page.click(`#rows tr[data-row="${cfg.second}"] td`);
      await page.waitForFunction((id) => document.getElementById("viewer").dataset.open === id, { timeout: 30000 }, cfg.second);
      ga = await geometry("#canvas-a");
      await page.mouse.move(...where(ga, px, py));
      result.switched = await readInspector();
      await page.mouse.move(0, 0);
      await shoot("switched_test", "#canvas-a");
      // the second seed, the error map and the FLIP map, each once as A
      for (const name of ["reference2", "error", "flip"]) {
        await page.select("#source-a", name);
        await page.mouse.move(0, 0);
        await shoot(`source_${name}`, "#canvas-a");
      }
      await page.select("#source-a", "test");
    }

    result.violations = await page.evaluate(() => window.__violations);
    result.console_before_control = result.console.length;
    // control: an inline script inserted now must be refused by the page's CSP and reported as a violation
    result.inline_ran = await page.evaluate(async () => {
      const s = document.createElement("script");
      s.textContent = "window.__inlineRan = true;";
      document.body.append(s);
      await new Promise((ok) => setTimeout(ok, 100));
      return window.__inlineRan === true;
    });
    result.violations_after_inline = await page.evaluate(() => window.__violations);
  } finally {
    await browser.close().catch(() => {});
    if (server) server.close();
  }
  await emit(result);
}

/** The hand-written report: the cases of the viewer's data handling, through the UI. */
async function synthetic(page, cfg, result) {
  const opened = (id) => page.waitForFunction((i) => document.getElementById("viewer").dataset.open === i, { timeout: 30000 }, id);
  const click = async (id, ctrl = false) => {
    if (ctrl) await page.keyboard.down("Control");
    await page.click(`#rows tr[data-row="${id}"] td`);
    if (ctrl) await page.keyboard.up("Control");
  };
  const message = () => page.$eval("#viewer-message", (e) => e.textContent);
  const shown = () => page.$eval("#viewer-panes", (e) => e.dataset.shown);
  // the pixel's centre in the fitted, centred image of a canvas cw x ch showing a square image of `n` pixels
  const inspectAt = async (n) => {
    const g = await page.$eval("#canvas-a", (c) => { const r = c.getBoundingClientRect(); return { left: r.left + c.clientLeft, top: r.top + c.clientTop, cw: c.width, ch: c.height }; });
    const s = Math.min(g.cw, g.ch) / n;
    const [x, y] = cfg.pixel;
    await page.mouse.move(g.left + (g.cw - s * n) / 2 + (x + 0.5) * s, g.top + (g.ch - s * n) / 2 + (y + 0.5) * s);
    const r = await page.$eval("#inspector", (e) => ({ ...e.dataset, text: e.textContent }));
    await page.mouse.move(0, 0);
    return r;
  };
  await page.goto(result.url, { waitUntil: "load" });
  await page.waitForFunction(() => document.documentElement.dataset.viewerReady === "true", { timeout: 30000 });

  // a row whose reference file also holds a "test" and an "error": only its reference images count
  await click(cfg.first);
  await opened(cfg.first);
  result.first = { inspector: await inspectAt(cfg.size), message: await message(),
    compare_options: await page.$$eval("#compare option", (os) => os.map((o) => o.value).filter(Boolean)) };

  // a second row of another size: refused, in one line
  await click(cfg.other_size, true);
  await page.waitForFunction(() => document.getElementById("viewer-message").textContent.length > 0, { timeout: 30000 });
  result.other_size = { message: await message(), compare: await page.$eval("#compare", (e) => e.value),
    b: await page.$eval("#source-b", (e) => e.value) };

  // two picks of the compared row, the first one slow: the latest pick stays
  await page.select("#compare", cfg.slow);
  await page.select("#compare", cfg.fast);
  await sleep(Math.max(...Object.values(cfg.delay)) + 1000);
  result.race = { compare: await page.$eval("#compare", (e) => e.value), inspector: await inspectAt(cfg.size) };

  // the f key while a select has the focus: nothing; then, with the focus elsewhere, it flips
  await page.focus("#compare");
  const before = await shown();
  await page.keyboard.press("f");
  const inSelect = await shown();
  await page.evaluate(() => document.activeElement.blur());
  await page.keyboard.press("f");
  result.f_key = { before, in_select: inSelect, outside: await shown() };
  await page.click("#mode-side");

  // a row whose reference file is missing: opened without it, and said
  await click(cfg.noref);
  await opened(cfg.noref);
  await page.select("#source-b", "reference");
  result.noref = { message: await message(), inspector: await inspectAt(cfg.size) };

  // a row of display values (an engine's tone-mapped image): sRGB only, no exposure
  await click(cfg.display);
  await opened(cfg.display);
  result.display = { inspector: await inspectAt(cfg.size), exposure_disabled: await page.$eval("#exposure", (e) => e.disabled),
    range_disabled: await page.$eval("#exposure-range", (e) => e.disabled),
    geometry: await page.$eval("#canvas-a", (c) => ({ cw: c.width, ch: c.height })) };
  result.screenshots.display = join(cfg.out, "display.png");
  await (await page.$("#canvas-a")).screenshot({ path: result.screenshots.display });

  // many rows, each with its own reference: what the viewer holds stays bounded
  for (const id of cfg.many) {
    await click(id);
    await opened(id);
  }
  result.held = await page.evaluate(() => window.iblcheckViewer.held());
  result.many_message = await message();
}

/** The result as one JSON line on stdout, resolved once written: stdout is a pipe, where a write is
 * asynchronous and process.exit() drops what is still queued (a result over the pipe's 64 KiB came back cut). */
function emit(result) {
  return new Promise((ok) => process.stdout.write(JSON.stringify(result) + "\n", ok));
}

main().then(
  () => process.exit(0),
  (e) => {
    process.stderr.write(`error: ${String(e?.message ?? e).split("\n")[0]}\n`);
    process.exit(e instanceof Missing ? 3 : 2);
  },
);
