#!/usr/bin/env node
// Renders an iblcheck export with three.js or Babylon.js in headless Chromium (SwiftShader through ANGLE, so
// it runs on CPU-only machines) and writes the linear radiance image as float32 OpenEXR.
//   node engines/web/render.mjs --engine threejs|babylon --sidecar FILE --output FILE.exr [--timings FILE.json]
//        [--frames N] [--warmup N]
// Exit codes: 0 the image was written; 2 one `error:` line: bad arguments, a sidecar or scene the engine cannot
// render; 3 one `error:` line: something missing on this machine (Chromium, node_modules, WebGL 2).
// IBLCHECK_CHROMIUM names the browser (default: chromium, chromium-browser or google-chrome on PATH).
import { existsSync, writeFileSync, renameSync, accessSync, constants } from "node:fs";
import { delimiter, dirname, join, resolve } from "node:path";
import { fileURLToPath, pathToFileURL } from "node:url";
import { readSidecar, SceneError } from "./lib/sidecar.mjs";
import { serve } from "./lib/server.mjs";
import { writeExr } from "./lib/exr.mjs";

const HERE = dirname(fileURLToPath(import.meta.url));
const ENGINES = ["threejs", "babylon"];
const PACKAGES = { threejs: ["three"], babylon: ["@babylonjs/core", "@babylonjs/loaders"] };

class Missing extends Error {}

function fail(code, message) {
  process.stderr.write(`error: ${String(message).split("\n")[0]}\n`);
  process.exit(code);
}

function parseArgs(argv) {
  const opts = { frames: 10, warmup: 2 };
  for (let i = 0; i < argv.length; i++) {
    const key = argv[i];
    const value = argv[i + 1];
    if (!["--engine", "--sidecar", "--output", "--timings", "--frames", "--warmup"].includes(key)) {
      throw new SceneError(`unknown argument ${JSON.stringify(key)} (usage: --engine threejs|babylon --sidecar FILE --output FILE.exr [--timings FILE.json] [--frames N] [--warmup N])`);
    }
    if (value === undefined) throw new SceneError(`${key} needs a value`);
    opts[key.slice(2)] = value;
    i++;
  }
  if (!ENGINES.includes(opts.engine)) throw new SceneError(`--engine ${JSON.stringify(opts.engine)} is not one of ${ENGINES.join(", ")}`);
  for (const k of ["sidecar", "output"]) if (!opts[k]) throw new SceneError(`--${k} is required`);
  for (const k of ["frames", "warmup"]) {
    const n = Number(opts[k]);
    if (!Number.isInteger(n) || n < (k === "frames" ? 1 : 0) || n > 1000) throw new SceneError(`--${k} ${JSON.stringify(opts[k])} must be an integer in [${k === "frames" ? 1 : 0}, 1000]`);
    opts[k] = n;
  }
  return opts;
}

function findChromium() {
  const named = process.env.IBLCHECK_CHROMIUM;
  const executable = (p) => { try { accessSync(p, constants.X_OK); return true; } catch { return false; } };
  if (named) {
    if (!executable(named)) throw new Missing(`IBLCHECK_CHROMIUM=${named} is not an executable file`);
    return named;
  }
  for (const dir of (process.env.PATH ?? "").split(delimiter)) {
    for (const name of ["chromium", "chromium-browser", "google-chrome"]) {
      if (dir && executable(join(dir, name))) return join(dir, name);
    }
  }
  throw new Missing("no Chromium found (chromium, chromium-browser or google-chrome on PATH, or IBLCHECK_CHROMIUM); " +
    "install Debian's chromium (make setup does, as root)");
}

function checkPackages(engine) {
  for (const pkg of ["puppeteer-core", ...PACKAGES[engine]]) {
    if (!existsSync(join(HERE, "node_modules", pkg, "package.json"))) {
      throw new Missing(`the npm package ${pkg} is not installed in ${join(HERE, "node_modules")}; run \`npm ci --prefix engines/web\` (make setup)`);
    }
  }
}

function writeAtomic(path, text) {
  const tmp = `${path}.tmp${process.pid}`;
  writeFileSync(tmp, text);
  renameSync(tmp, path);
}

async function main() {
  const t0 = performance.now();
  const opts = parseArgs(process.argv.slice(2));
  const sidecar = readSidecar(resolve(opts.sidecar));
  const chromium = findChromium();
  checkPackages(opts.engine);
  // deferred: puppeteer-core is absent until `npm ci`, which checkPackages has just reported
  const { default: puppeteer } = await import(pathToFileURL(join(HERE, "node_modules", "puppeteer-core", "lib", "esm", "puppeteer", "puppeteer-core.js")).href);
  const { server, url } = await serve({ engine: HERE, scene: sidecar.folder });
  let browser;
  try {
    const args = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist",
      "--disable-dev-shm-usage", "--no-first-run", "--no-default-browser-check", "--disable-extensions"];
    if (process.getuid?.() === 0) args.push("--no-sandbox");
    try {
      browser = await puppeteer.launch({ executablePath: chromium, headless: true, args, timeout: 120000, protocolTimeout: 600000 });
    } catch (e) {
      throw new Missing(`${chromium} did not start headless: ${String(e.message).split("\n")[0]}`);
    }
    const page = await browser.newPage();
    const consoleLines = [];
    page.on("console", (m) => consoleLines.push(m.text()));
    page.on("pageerror", (e) => consoleLines.push(String(e.message)));
    await page.goto(`${url}/engine/page/index.html?engine=${opts.engine}`, { waitUntil: "load" });
    await page.waitForFunction("window.iblcheckReady === true", { timeout: 60000 });
    const startupMs = performance.now() - t0;
    const result = await page.evaluate((cfg) => window.iblcheckRender(cfg), {
      gltf: sidecar.gltf, environment: sidecar.environment, camera: sidecar.camera,
      width: sidecar.width, height: sidecar.height, frames: opts.frames, warmup: opts.warmup,
    });
    if (!result.ok) {
      const detail = consoleLines.filter((l) => /error/i.test(l)).slice(-1)[0];
      const msg = `${opts.engine}: ${result.message}${detail && !result.message.includes(detail) ? ` (console: ${detail})` : ""}`;
      if (result.kind === "missing") throw new Missing(msg);
      throw new SceneError(msg);
    }
    const rgb = new Float32Array(Buffer.from(result.rgb, "base64").buffer.slice(0));
    if (rgb.length !== sidecar.width * sidecar.height * 3) throw new SceneError(`${opts.engine} returned ${rgb.length} values, not ${sidecar.width}x${sidecar.height}x3`);
    let bad = 0;
    for (const v of rgb) if (!Number.isFinite(v)) bad++;
    if (bad) throw new SceneError(`${opts.engine} produced ${bad} non-finite values in ${opts.sidecar}; nothing written`);
    writeExr(resolve(opts.output), rgb, sidecar.width, sidecar.height);
    if (opts.timings) {
      const timings = {
        engine: result.engine, version: result.version, frame_ms: result.frame_ms, precompute_ms: result.precompute_ms,
        median_frame_ms: result.median_frame_ms, load_ms: result.load_ms, first_frame_ms: result.first_frame_ms,
        ...(result.ready_ms !== undefined ? { ready_ms: result.ready_ms } : {}),
        startup_ms: startupMs, total_ms: performance.now() - t0,
        browser: await browser.version(),
        notes: `CPU times (SwiftShader, no GPU); ${result.notes}`,
      };
      writeAtomic(resolve(opts.timings), JSON.stringify(timings, null, 2) + "\n");
    }
  } finally {
    if (browser) await browser.close().catch(() => {});
    server.close();
  }
}

main().then(
  () => process.exit(0),
  (e) => {
    if (e instanceof Missing) fail(3, e.message);
    if (e instanceof SceneError) fail(2, e.message);
    fail(2, `${e?.name ?? "Error"}: ${e?.message ?? e}`);
  },
);
