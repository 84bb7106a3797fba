#!/usr/bin/env node
// Drives an iblcheck report's viewer (experiments/publish/viewer/viewer.js) in headless Chromium for
// tests/experiments/test_report_viewer_browser.py, and prints what it saw as one JSON object on stdout.
//   node tests/experiments/report_driver.mjs CONFIG.json
// CONFIG: {"report": DIR, "http": bool (serve DIR from a static server on 127.0.0.1, else open file://),
//          "out": DIR (screenshots), "row": RID, "second": RID, "nodata": RID | null, "width": W, "height": H,
//          "pixels": [[x, y], ...], "exposure": stops, "filter_scene": NAME, "sort_header": TEXT}
// Everything the page does is through its UI: clicks, keys, mouse drags and wheel, as a user would; the
// pixel under the cursor is found from the geometry of a fitted, centred image, not from the viewer's state.
// Exit 0 with the JSON; 3 and one `error:` line when Chromium or puppeteer-core is missing; 2 on a failure.
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
function serve(root) {
  root = resolve(root);
  const server = createServer(async (req, res) => {
    const rel = decodeURIComponent(new URL(req.url, "http://127.0.0.1").pathname);
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
    const s = await serve(cfg.report);
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
    page.on("requestfailed", (r) => result.failed.push(`${r.url()}: ${r.failure()?.errorText}`));
    result.bad_responses = [];
    page.on("response", (r) => { if (r.status() >= 400) result.bad_responses.push(`${r.status()} ${r.url()}`); });
    await page.evaluateOnNewDocument(() => {
      window.__violations = [];
      document.addEventListener("securitypolicyviolation", (e) => {
        window.__violations.push({ directive: e.violatedDirective, blocked: e.blockedURI, sample: e.sample });
      });
    });

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
  process.stdout.write(JSON.stringify(result) + "\n");
}

main().then(
  () => process.exit(0),
  (e) => {
    process.stderr.write(`error: ${String(e?.message ?? e).split("\n")[0]}\n`);
    process.exit(e instanceof Missing ? 3 : 2);
  },
);
