// iblcheck report viewer: sortable tables, row filters, and an HDR image viewer for the rows of #rows.
//
// Plain JavaScript, no library, nothing from the network, no eval: the page's Content-Security-Policy
// allows only the report folder's own scripts. A row's images are loaded when it is opened, by inserting
// <script src="viewer/rows/RID.js">: that file calls window.iblcheckViewer.add({...}) with its images as
// zlib-compressed (DecompressionStream "deflate") little-endian float16 or uint8 arrays in base64, row 0 at
// the top. Its reference's images come the same way from viewer/refs/REFID.js.
//
// Display of linear radiance: sRGB(Reinhard(x * 2^stops)) with the row's tone mapping, the formula of
// scenes/model/tonemap.py (reinhard, then srgb_encode, then rounding to 8 bits). Error and FLIP maps are
// shown with fixed colour maps (inferno over [0, max of the row's error], magma over [0, 1]); pixels outside
// the mask are grey. Every zoom draws with nearest-neighbour sampling so single pixels stay visible.
"use strict";

(function () {
  const SOURCES = [
    ["test", "test (real-time)"], ["reference", "reference"], ["reference2", "reference, second seed"],
    ["error", "error map"], ["flip", "FLIP map"], ["other", "test of the compared row"],
  ];
  const MAPS = { error: "inferno", flip: "magma" };
  // matplotlib's inferno and magma at 0, 1/8, ..., 1 (8-bit sRGB), linearly interpolated between
  const COLORMAPS = {
    inferno: [[0, 0, 4], [31, 12, 72], [85, 15, 109], [136, 34, 106], [186, 54, 85], [227, 89, 51],
      [249, 140, 10], [249, 201, 50], [252, 255, 164]],
    magma: [[0, 0, 4], [28, 16, 68], [79, 18, 123], [129, 37, 129], [181, 54, 122], [229, 80, 100],
      [251, 135, 97], [254, 194, 135], [252, 253, 191]],
  };
  const MASKED = [128, 128, 128];
  const BACKGROUND = "#1e1e1e";
  const CACHE_ROWS = 8; // decoded rows kept in memory (a 300-row report never holds them all)
  const SAFE_PATH = /^(?![a-zA-Z][a-zA-Z0-9+.-]*:)(?!\/)(?!.*\.\.)[\w./-]+$/;
  const SAFE_ID = /^[\w.-]+$/;

  // ------------------------------------------------------------------------------------- data files

  // A data file's add() call is matched to the <script> that loads it (document.currentScript, set while
  // that script runs), so a file answers only its own request: a reference file can never stand for a row,
  // nor a row for a reference, and rows and references are kept in separate maps. Nothing keeps a data
  // file's object (its base64 text) once the one waiting request has it: the decoded images are cached
  // (rows and references each in a bounded LRU) instead.
  const pending = { row: new Map(), ref: new Map() }; // kind -> id -> {resolve, reject, done}

  window.iblcheckViewer = Object.freeze({
    add(obj) {
      const s = document.currentScript;
      if (!s || !obj || typeof obj !== "object" || typeof obj.id !== "string") return;
      const kind = s.dataset.kind, want = s.dataset.id;
      const job = pending[kind] && pending[kind].get(want);
      if (!job || obj.id !== want) return;
      pending[kind].delete(want);
      job.done = true;
      job.resolve(obj);
    },
    /** How much the viewer holds: data objects not yet handed over, decoded rows and references. */
    held() {
      return { pending: pending.row.size + pending.ref.size, rows: decoded.size, refs: decodedRefs.size };
    },
  });

  /** The object data file `src` passes to add() under `id` (kind "row" or "ref"), loaded once per call. */
  function loadData(src, id, kind) {
    if (!SAFE_PATH.test(src)) return Promise.reject(new Error(`refused data file ${src}`));
    if (pending[kind].has(id)) return pending[kind].get(id).promise;
    const job = { done: false };
    job.promise = new Promise((resolve, reject) => {
      job.resolve = resolve;
      const s = document.createElement("script");
      const fail = (why) => {
        s.remove();
        if (job.done) return;
        job.done = true;
        if (pending[kind].get(id) === job) pending[kind].delete(id);
        reject(new Error(why));
      };
      s.dataset.kind = kind;
      s.dataset.id = id;
      s.src = src;
      s.onload = () => fail(`${src} holds no data for ${id}`); // a no-op when add() already answered
      s.onerror = () => fail(`could not load ${src}`);
      document.head.appendChild(s);
    });
    pending[kind].set(id, job);
    return job.promise;
  }

  // IEEE 754 binary16 -> float32, through a table of all 65536 codes (built on first use)
  let HALF = null;
  function halfTable() {
    if (HALF) return HALF;
    HALF = new Float32Array(65536);
    for (let h = 0; h < 65536; h++) {
      const sign = h & 0x8000 ? -1 : 1;
      const e = (h >> 10) & 0x1f;
      const m = h & 0x3ff;
      if (e === 0) HALF[h] = sign * m * 2 ** -24; // subnormal: m / 1024 * 2^-14
      else if (e === 31) HALF[h] = m ? NaN : sign * Infinity;
      else HALF[h] = sign * (1 + m / 1024) * 2 ** (e - 15);
    }
    return HALF;
  }

  async function inflate(b64) {
    const bin = atob(b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("deflate"));
    return new Response(stream).arrayBuffer();
  }

  /** An IMG object of a data file -> {w, h, c, data: Float32Array | Uint8Array}. */
  async function decode(img, w, h, name) {
    if (!img || img.codec !== "deflate" || ![1, 3].includes(img.channels) || !["f16", "u8"].includes(img.dtype)) {
      throw new Error(`image ${name}: unknown format`);
    }
    const buf = await inflate(img.data);
    const n = w * h * img.channels;
    let data;
    if (img.dtype === "u8") {
      data = new Uint8Array(buf);
    } else {
      if (buf.byteLength !== 2 * n) throw new Error(`image ${name}: ${buf.byteLength} bytes, not ${2 * n}`);
      const codes = new Uint16Array(buf); // little-endian, as every browser's platform
      const table = halfTable();
      data = new Float32Array(n);
      for (let i = 0; i < n; i++) data[i] = table[codes[i]];
    }
    if (data.length !== n) throw new Error(`image ${name}: ${data.length} values, not ${w} x ${h} x ${img.channels}`);
    return { w, h, c: img.channels, data, clamped: img.clamped || 0, bitmap: null, bitmapKey: null };
  }

  const decoded = new Map(); // row id -> Promise of a decoded row, most recently used last
  const decodedRefs = new Map(); // reference id -> Promise of its decoded images, most recently used last
  const REF_IMAGES = ["reference", "reference2"]; // all a reference file may contribute to a row

  /** The cached promise under `key` (marked most recently used), else make() cached, within CACHE_ROWS. */
  function cached(cache, key, make) {
    if (cache.has(key)) {
      const p = cache.get(key);
      cache.delete(key);
      cache.set(key, p);
      return p;
    }
    const p = make();
    cache.set(key, p);
    p.catch(() => { if (cache.get(key) === p) cache.delete(key); });
    while (cache.size > CACHE_ROWS) cache.delete(cache.keys().next().value);
    return p;
  }

  /** A reference's images, decoded: {reference, reference2} (only those names, whatever the file holds). */
  function openReference(src, refId, w, h) {
    return cached(decodedRefs, refId, async () => {
      const ref = await loadData(src, `ref-${refId}`, "ref");
      if (ref.width !== w || ref.height !== h) throw new Error(`${src}: ${ref.width} x ${ref.height}, not the row's ${w} x ${h}`);
      const images = {};
      await Promise.all(REF_IMAGES.filter((k) => ref.images && ref.images[k])
        .map(async (k) => { images[k] = await decode(ref.images[k], w, h, k); }));
      return images;
    });
  }

  /** A row's images decoded: {id, label, w, h, tonemap, display, images: {name: image}, warning}. A missing
   * or broken reference leaves the row without its reference images, and `warning` says why. */
  function openRow(tr) {
    const id = tr.dataset.row;
    return cached(decoded, id, async () => {
      const src = tr.dataset.data;
      let row = await loadData(src, id, "row");
      const w = row.width, h = row.height;
      if (!Number.isInteger(w) || !Number.isInteger(h) || w < 1 || h < 1) throw new Error(`${src}: no image size`);
      const images = {};
      const jobs = Object.entries(row.images || {}).filter(([k]) => !REF_IMAGES.includes(k))
        .map(async ([k, v]) => { images[k] = await decode(v, w, h, k); });
      const info = { id, label: row.label || id, w, h, tonemap: row.tonemap || null, psnr: row.psnr,
        display: row.display === "srgb" ? "srgb" : "linear", images, warning: "" };
      const refId = row.reference;
      row = null; // the base64 text is not kept past decoding
      if (refId && SAFE_ID.test(refId)) {
        const refSrc = /rows\/[^/]*$/.test(src) ? src.replace(/rows\/[^/]*$/, `refs/${refId}.js`) : `viewer/refs/${refId}.js`;
        jobs.push(openReference(refSrc, refId, w, h).then(
          (refImages) => { for (const k of REF_IMAGES) if (refImages[k]) images[k] = refImages[k]; },
          (err) => { info.warning = `reference ${refId} not shown: ${err.message}`; },
        ));
      } else if (refId) info.warning = `reference ${refId} not shown: not a plain id`;
      await Promise.all(jobs);
      return info;
    });
  }

  // ------------------------------------------------------------------------------------- display

  /** scenes/model/tonemap.py: reinhard (clamped at white) then srgb_encode, then 8 bits. */
  function displayByte(x, scale, white) {
    let v = x * scale;
    if (Number.isNaN(v)) v = 0;
    v = Math.min(Math.max(v, 0), white);
    v = v * (1 + v / (white * white)) / (1 + v);
    return srgbByte(v);
  }

  /** srgb_encode of a display-linear value clamped to [0, 1], then 8 bits (no tone mapping, no exposure). */
  function srgbByte(x) {
    let v = Number.isNaN(x) ? 0 : Math.min(Math.max(x, 0), 1);
    v = v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055;
    return Math.round(v * 255);
  }

  function colormap(name, t) {
    const stops = COLORMAPS[name];
    const u = Math.min(Math.max(Number.isNaN(t) ? 0 : t, 0), 1) * (stops.length - 1);
    const i = Math.min(Math.floor(u), stops.length - 2);
    const f = u - i;
    return stops[i].map((a, k) => Math.round(a + (stops[i + 1][k] - a) * f));
  }

  /** Is this image of `row` display values (a tone-mapped engine image: sRGB-encoded only), not radiance? */
  const isDisplay = (row, name) => row.display === "srgb" && name === "test";

  /** The 8-bit RGBA picture of one image at `stops` (cached on the image while the stops stay). */
  function bitmap(row, name, img, stops) {
    const key = MAPS[name] ? "map" : isDisplay(row, name) ? "srgb" : `x${stops}`;
    if (img.bitmap && img.bitmapKey === key) return img.bitmap;
    const { w, h, c, data } = img;
    const px = new ImageData(w, h);
    const out = px.data;
    const mask = row.images.mask;
    if (MAPS[name]) {
      let top = 1;
      if (name === "error") {
        top = 0;
        for (let i = 0; i < w * h; i++) if ((!mask || mask.data[i]) && data[i * c] > top) top = data[i * c];
        if (!(top > 0)) top = 1e-6;
      }
      img.top = top;
      for (let i = 0; i < w * h; i++) {
        const rgb = mask && !mask.data[i] ? MASKED : colormap(MAPS[name], data[i * c] / top);
        out.set(rgb, 4 * i);
        out[4 * i + 3] = 255;
      }
    } else if (key === "srgb") {
      for (let i = 0; i < w * h; i++) {
        for (let k = 0; k < 3; k++) out[4 * i + k] = srgbByte(data[i * c + (c === 3 ? k : 0)]);
        out[4 * i + 3] = 255;
      }
    } else {
      const t = row.tonemap || {};
      const key0 = t.key ?? 0.18, white = t.white ?? 1e30, adapt = Math.max(t.adapt_lum ?? 1, 1e-30);
      const scale = key0 / adapt * 2 ** (t.exposure ?? 0) * 2 ** stops;
      for (let i = 0; i < w * h; i++) {
        for (let k = 0; k < 3; k++) out[4 * i + k] = displayByte(data[i * c + (c === 3 ? k : 0)], scale, white);
        out[4 * i + 3] = 255;
      }
    }
    const canvas = document.createElement("canvas");
    canvas.width = w;
    canvas.height = h;
    canvas.getContext("2d").putImageData(px, 0, 0);
    img.bitmap = canvas;
    img.bitmapKey = key;
    return canvas;
  }

  // ------------------------------------------------------------------------------------- page

  function el(tag, attrs = {}, ...children) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs)) {
      if (k === "text") e.textContent = v;
      else e.setAttribute(k, v);
    }
    for (const c of children) e.append(c);
    return e;
  }

  function makeSortable(table) {
    const head = table.tHead || table.querySelector("tr");
    if (!head) return;
    for (const th of head.querySelectorAll("th")) {
      th.addEventListener("click", () => {
        const body = table.tBodies[0];
        if (!body) return;
        const col = th.cellIndex;
        const asc = th.getAttribute("data-order") !== "asc";
        const rows = Array.from(body.rows);
        const key = (r) => (r.cells[col] ? r.cells[col].textContent.trim() : "");
        rows.sort((a, b) => {
          const x = key(a), y = key(b);
          const nx = parseFloat(x), ny = parseFloat(y);
          let c;
          if (!Number.isNaN(nx) && !Number.isNaN(ny)) c = nx - ny;
          else if (Number.isNaN(nx) !== Number.isNaN(ny)) return Number.isNaN(nx) ? 1 : -1; // '-' last
          else c = x.localeCompare(y);
          return asc ? c : -c;
        });
        for (const r of rows) body.appendChild(r);
        for (const other of head.querySelectorAll("th")) other.removeAttribute("data-order");
        th.setAttribute("data-order", asc ? "asc" : "desc");
      });
    }
  }

  function makeFilters(table) {
    const rows = Array.from(table.tBodies[0] ? table.tBodies[0].rows : []);
    const fields = [["scene", (r) => [r.dataset.scene]], ["technique", (r) => [r.dataset.technique]],
      ["effect", (r) => (r.dataset.effects || "").split(/\s+/)]];
    const bar = el("div", { id: "filters", class: "iv-filters" });
    const selects = {};
    for (const [name, values] of fields) {
      const set = new Set();
      for (const r of rows) for (const v of values(r)) if (v) set.add(v);
      const sel = el("select", { id: `filter-${name}`, "aria-label": `filter by ${name}` },
        el("option", { value: "", text: `every ${name}` }));
      for (const v of Array.from(set).sort()) sel.append(el("option", { value: v, text: v }));
      sel.addEventListener("change", apply);
      selects[name] = [sel, values];
      bar.append(el("label", {}, `${name} `, sel));
    }
    const count = el("span", { id: "filter-count", class: "iv-count" });
    bar.append(count);
    function apply() {
      let shown = 0;
      for (const r of rows) {
        const ok = Object.values(selects).every(([sel, values]) => !sel.value || values(r).includes(sel.value));
        r.hidden = !ok;
        shown += ok;
      }
      count.textContent = `${shown} of ${rows.length} rows`;
    }
    apply();
    table.parentNode.insertBefore(bar, table);
  }

  // ------------------------------------------------------------------------------------- the viewer

  function makeViewer(root, table) {
    const allRows = Array.from(table.tBodies[0] ? table.tBodies[0].rows : []).filter((r) => r.dataset.row);
    const state = {
      row: null, other: null, a: "test", b: "reference", mode: "side", flipB: false, stops: 0,
      view: null, divider: 0.5, cursor: null,
    };

    const title = el("div", { id: "viewer-title", class: "iv-title", text: "Click a row of the table to open it here (ctrl- or shift-click a second row to compare the two)." });
    const message = el("div", { id: "viewer-message", class: "iv-message", role: "status" });
    const modeButtons = {};
    const modes = el("span", { class: "iv-modes" });
    for (const [m, text] of [["side", "side by side"], ["flip", "flip"], ["swipe", "swipe"]]) {
      const b = el("button", { type: "button", id: `mode-${m}`, text });
      b.addEventListener("click", () => setMode(m));
      modeButtons[m] = b;
      modes.append(b);
    }
    const flipButton = el("button", { type: "button", id: "flip-toggle", title: "key f", text: "A/B (f)" });
    flipButton.addEventListener("click", () => toggleFlip());
    const selA = el("select", { id: "source-a", "aria-label": "image A" });
    const selB = el("select", { id: "source-b", "aria-label": "image B" });
    for (const sel of [selA, selB]) for (const [v, text] of SOURCES) sel.append(el("option", { value: v, text }));
    selA.value = state.a; // the selects start at what is shown, not at their first option
    selB.value = state.b;
    selA.addEventListener("change", () => { state.a = selA.value; draw(); });
    selB.addEventListener("change", () => { state.b = selB.value; draw(); });
    const compare = el("select", { id: "compare", "aria-label": "compare with row" }, el("option", { value: "", text: "no second row" }));
    /** The compare list for the open row `tr`: the other rows of its scene first, then the rest. */
    function listCompare(tr) {
      const scene = tr ? tr.dataset.scene : null;
      const rows = allRows.filter((r) => r.dataset.data && r !== tr);
      const same = rows.filter((r) => r.dataset.scene === scene), rest = rows.filter((r) => r.dataset.scene !== scene);
      const option = (r) => el("option", { value: r.dataset.row,
        text: Array.from(r.cells).slice(0, 3).map((c) => c.textContent.trim()).join(" / ") });
      const keep = state.other ? state.other.id : "";
      compare.replaceChildren(el("option", { value: "", text: "no second row" }));
      if (same.length) compare.append(el("optgroup", { label: "same scene" }, ...same.map(option)));
      if (rest.length) compare.append(el("optgroup", { label: "other scenes" }, ...rest.map(option)));
      compare.value = keep;
    }
    listCompare(null);
    compare.addEventListener("change", () => {
      const tr = allRows.find((r) => r.dataset.row === compare.value);
      setOther(tr || null);
    });
    const range = el("input", { type: "range", id: "exposure-range", min: "-12", max: "12", step: "0.25", value: "0", "aria-label": "exposure (stops)" });
    const number = el("input", { type: "number", id: "exposure", min: "-40", max: "40", step: "0.25", value: "0", "aria-label": "exposure (stops)" });
    /** The stops in use: none for a row whose test image is display values (its control is disabled). */
    const stops = () => (state.row && state.row.display === "srgb" ? 0 : state.stops);
    const onExposure = (src) => () => {
      const v = parseFloat(src.value);
      if (!Number.isFinite(v)) return;
      state.stops = Math.min(Math.max(v, -40), 40);
      if (src !== range) range.value = String(state.stops);
      if (src !== number) number.value = String(state.stops);
      draw();
    };
    range.addEventListener("input", onExposure(range));
    number.addEventListener("input", onExposure(number));
    number.addEventListener("change", onExposure(number));
    const reset = el("button", { type: "button", id: "reset-view", text: "fit" });
    reset.addEventListener("click", () => { state.view = null; draw(); });

    const controls = el("div", { class: "iv-controls" }, modes, " ", flipButton, " ",
      el("label", {}, "A ", selA), " ", el("label", {}, "B ", selB), " ", el("label", {}, "compare with ", compare), " ",
      el("label", {}, "exposure ", range, number, " stops"), " ", reset);
    const canvasA = el("canvas", { id: "canvas-a", class: "iv-canvas", width: "448", height: "448" });
    const canvasB = el("canvas", { id: "canvas-b", class: "iv-canvas", width: "448", height: "448" });
    const divider = el("div", { id: "swipe-divider", class: "iv-divider", role: "separator", "aria-orientation": "vertical" });
    const captionA = el("div", { id: "caption-a", class: "iv-caption" });
    const captionB = el("div", { id: "caption-b", class: "iv-caption" });
    const paneA = el("div", { id: "pane-a", class: "iv-pane" }, el("div", { class: "iv-stage" }, canvasA, divider), captionA);
    const paneB = el("div", { id: "pane-b", class: "iv-pane" }, el("div", { class: "iv-stage" }, canvasB), captionB);
    const panes = el("div", { id: "viewer-panes", class: "iv-panes" }, paneA, paneB);
    const inspector = el("div", { id: "inspector", class: "iv-inspector", text: "move the cursor over an image" });
    const body = el("div", { id: "viewer-body", class: "iv-body", hidden: "" }, controls, panes, inspector);
    root.append(title, message, body);

    function say(text) { message.textContent = text; }

    function images() {
      const r = state.row;
      const pick = (name) => {
        if (name === "other") return state.other ? { row: state.other, img: state.other.images.test, name: "test", who: state.other } : null;
        return r.images[name] ? { row: r, img: r.images[name], name, who: r } : null;
      };
      return { A: pick(state.a), B: pick(state.b) };
    }

    function describe(src, letter, fallback) {
      if (!src) return `${letter}: ${fallback} (not in this row's data)`;
      const what = SOURCES.find(([v]) => v === src.name)[1];
      let text = `${letter}: ${src.who === state.row ? "" : `${src.who.label} — `}${what}`;
      if (MAPS[src.name]) text += ` (${MAPS[src.name]}, 0 to ${(src.img.top ?? 1).toPrecision(3)})`;
      if (src.img.clamped) text += ` (${src.img.clamped} values clamped to 65504)`;
      return text;
    }

    function fit() {
      const r = state.row;
      const cw = canvasA.width, ch = canvasA.height;
      const s = Math.min(cw / r.w, ch / r.h);
      return { s, tx: (cw - s * r.w) / 2, ty: (ch - s * r.h) / 2 };
    }

    function paint(canvas, src, clipFrom) {
      const ctx = canvas.getContext("2d");
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      if (clipFrom === undefined) {
        ctx.fillStyle = BACKGROUND;
        ctx.fillRect(0, 0, canvas.width, canvas.height);
      } else {
        ctx.save();
        ctx.beginPath();
        ctx.rect(clipFrom, 0, canvas.width - clipFrom, canvas.height);
        ctx.clip();
        ctx.fillStyle = BACKGROUND;
        ctx.fillRect(0, 0, canvas.width, canvas.height);
      }
      if (src) {
        const v = state.view;
        ctx.imageSmoothingEnabled = false; // nearest neighbour at every zoom
        ctx.setTransform(v.s, 0, 0, v.s, v.tx, v.ty);
        ctx.drawImage(bitmap(src.row, src.name, src.img, stops()), 0, 0);
      }
      if (clipFrom !== undefined) ctx.restore();
    }

    function draw() {
      if (!state.row) return;
      if (!state.view) state.view = fit();
      const { A, B } = images();
      for (const [m, b] of Object.entries(modeButtons)) b.setAttribute("aria-pressed", String(m === state.mode));
      paneB.hidden = state.mode !== "side";
      divider.hidden = state.mode !== "swipe";
      flipButton.disabled = state.mode === "side";
      if (state.mode === "side") {
        paint(canvasA, A);
        paint(canvasB, B);
        captionA.textContent = describe(A, "A", state.a);
        captionB.textContent = describe(B, "B", state.b);
      } else if (state.mode === "flip") {
        paint(canvasA, state.flipB ? B : A);
        captionA.textContent = `showing ${state.flipB ? describe(B, "B", state.b) : describe(A, "A", state.a)}; f toggles`;
      } else {
        const x = Math.round(state.divider * canvasA.width);
        paint(canvasA, A);
        paint(canvasA, B, x);
        divider.style.left = `${x - 6}px`; // its 2-pixel line (viewer.css) covers columns x - 1 and x
        divider.dataset.position = state.divider.toFixed(4);
        captionA.textContent = `${describe(A, "A", state.a)} | ${describe(B, "B", state.b)}`;
      }
      panes.dataset.mode = state.mode;
      panes.dataset.shown = state.mode === "flip" ? (state.flipB ? "B" : "A") : "AB";
      inspect();
    }

    function setMode(m) {
      state.mode = m;
      if (m !== "flip") state.flipB = false;
      draw();
    }

    function toggleFlip() {
      if (state.mode !== "flip") { state.mode = "flip"; state.flipB = true; } else state.flipB = !state.flipB;
      draw();
    }

    const fmt = (x) => (Number.isFinite(x) ? x.toPrecision(4) : String(x));

    function pixel(src, x, y) {
      if (!src || x < 0 || y < 0 || x >= src.img.w || y >= src.img.h) return null;
      const { c, data } = src.img;
      const i = (y * src.img.w + x) * c;
      return Array.from(data.subarray(i, i + c));
    }

    function inspect() {
      if (!state.row || !state.cursor) return;
      const v = state.view;
      const x = Math.floor((state.cursor.x - v.tx) / v.s), y = Math.floor((state.cursor.y - v.ty) / v.s);
      const { A, B } = images();
      const a = pixel(A, x, y), b = pixel(B, x, y);
      let d = null;
      if (a && b) {
        const n = Math.max(a.length, b.length);
        d = Array.from({ length: n }, (_, k) => a[Math.min(k, a.length - 1)] - b[Math.min(k, b.length - 1)]);
      }
      const show = (vals) => (vals ? vals.map(fmt).join(" ") : "-");
      // display values (a tone-mapped engine image), linear radiance, or a map's value
      const kind = (src) => (!src ? "" : MAPS[src.name] ? "map" : isDisplay(src.row, src.name) ? "display" : "linear");
      inspector.dataset.kindA = kind(A);
      inspector.dataset.kindB = kind(B);
      inspector.dataset.x = String(x);
      inspector.dataset.y = String(y);
      inspector.dataset.a = show(a);
      inspector.dataset.b = show(b);
      inspector.dataset.d = show(d);
      inspector.textContent = `x ${x}, y ${y} | A (${state.a}, ${kind(A) || "-"}): ${show(a)} | `
        + `B (${state.b}, ${kind(B) || "-"}): ${show(b)} | A - B: ${show(d)}`;
    }

    // pan and zoom, shared by both canvases (synchronised); the cursor feeds the inspector
    let drag = null;
    for (const canvas of [canvasA, canvasB]) {
      const at = (e) => {
        const r = canvas.getBoundingClientRect(); // its border box: the drawing starts inside the border
        return {
          x: (e.clientX - r.left - canvas.clientLeft) * canvas.width / canvas.clientWidth,
          y: (e.clientY - r.top - canvas.clientTop) * canvas.height / canvas.clientHeight,
        };
      };
      canvas.addEventListener("wheel", (e) => {
        if (!state.row) return;
        e.preventDefault();
        const p = at(e), v = state.view;
        const f0 = fit().s;
        const s = Math.min(Math.max(v.s * Math.exp(-e.deltaY * 0.002), f0 / 8), 512);
        const k = s / v.s;
        state.view = { s, tx: p.x - (p.x - v.tx) * k, ty: p.y - (p.y - v.ty) * k };
        state.cursor = p;
        draw();
      }, { passive: false });
      canvas.addEventListener("pointerdown", (e) => {
        if (!state.row || e.button !== 0) return;
        canvas.setPointerCapture(e.pointerId);
        drag = { p: at(e), view: { ...state.view } };
      });
      canvas.addEventListener("pointermove", (e) => {
        if (!state.row) return;
        const p = at(e);
        state.cursor = p;
        if (drag) {
          state.view = { ...drag.view, tx: drag.view.tx + p.x - drag.p.x, ty: drag.view.ty + p.y - drag.p.y };
          draw();
        } else inspect();
      });
      const end = () => { drag = null; };
      canvas.addEventListener("pointerup", end);
      canvas.addEventListener("pointercancel", end);
      canvas.addEventListener("dblclick", () => { state.view = null; draw(); });
    }
    divider.addEventListener("pointerdown", (e) => {
      e.stopPropagation();
      divider.setPointerCapture(e.pointerId);
      const move = (ev) => {
        const r = canvasA.getBoundingClientRect();
        state.divider = Math.min(Math.max((ev.clientX - r.left - canvasA.clientLeft) / canvasA.clientWidth, 0), 1);
        draw();
      };
      const up = () => {
        divider.removeEventListener("pointermove", move);
        divider.removeEventListener("pointerup", up);
        divider.removeEventListener("pointercancel", up);
      };
      divider.addEventListener("pointermove", move);
      divider.addEventListener("pointerup", up);
      divider.addEventListener("pointercancel", up);
    });
    document.addEventListener("keydown", (e) => {
      if (!state.row || e.ctrlKey || e.metaKey || e.altKey) return;
      const t = e.target;
      if (t && (["INPUT", "SELECT", "TEXTAREA"].includes(t.tagName) || t.isContentEditable)) return;
      if (e.key === "f" || e.key === "F") { e.preventDefault(); toggleFlip(); }
    });

    function mark() {
      for (const r of allRows) {
        r.classList.toggle("iv-open", !!state.row && r.dataset.row === state.row.id);
        r.classList.toggle("iv-compared", !!state.other && r.dataset.row === state.other.id);
      }
    }

    let ticket = 0;
    async function load(tr) {
      if (!tr.dataset.data) {
        const why = tr.dataset.why || "the report kept no images for it";
        return Promise.reject(new Error(`no images to view: ${why}`));
      }
      return openRow(tr);
    }

    async function open(tr) {
      const mine = ++ticket;
      const t0 = performance.now();
      say(`loading ${tr.dataset.row} ...`);
      try {
        const row = await load(tr);
        if (mine !== ticket) return;
        const resize = !state.row || state.row.w !== row.w || state.row.h !== row.h;
        state.row = row;
        if (state.other && (state.other.id === row.id || state.other.w !== row.w || state.other.h !== row.h)) {
          state.other = null;
          if (state.b === "other") state.b = selB.value = "reference";
        }
        otherTicket++; // a compared row still loading was picked for the previous row
        listCompare(tr);
        for (const input of [range, number]) {
          input.disabled = row.display === "srgb";
          input.title = input.disabled ? "this row's test image is display values (tone-mapped by its engine): no exposure" : "";
        }
        if (resize) {
          const side = 448;
          const h = Math.round(Math.min(Math.max(side * row.h / row.w, 160), 640));
          for (const c of [canvasA, canvasB]) { c.width = side; c.height = h; }
          state.view = null;
        }
        body.hidden = false;
        title.textContent = `${row.label}${row.psnr != null ? ` — PSNR ${Number(row.psnr).toFixed(2)} dB` : ""}`;
        say([row.warning, row.tonemap ? "" : "this row kept no tone mapping: shown with Reinhard key 0.18, adaptation luminance 1"]
          .filter(Boolean).join("; "));
        mark();
        draw();
        root.dataset.openMs = (performance.now() - t0).toFixed(1);
        root.dataset.open = row.id;
        if (root.scrollIntoView) root.scrollIntoView({ block: "nearest" });
      } catch (err) {
        if (mine !== ticket) return;
        say(`${tr.dataset.row}: ${err.message}`);
      }
    }

    let otherTicket = 0; // the latest pick of a compared row: a slower earlier pick arriving later is dropped
    async function setOther(tr) {
      const mine = ++otherTicket;
      if (!tr) { state.other = null; compare.value = ""; if (state.b === "other") state.b = selB.value = "reference"; mark(); draw(); return; }
      try {
        const row = await load(tr);
        if (mine !== otherTicket) return;
        if (row.w !== state.row.w || row.h !== state.row.h) {
          compare.value = state.other ? state.other.id : "";
          say(`${row.id} is ${row.w} x ${row.h}, the open row ${state.row.w} x ${state.row.h}: only rows of one size can be compared`);
          return;
        }
        state.other = row;
        compare.value = row.id;
        state.a = selA.value = "test";
        state.b = selB.value = "other";
        say("");
        mark();
        draw();
      } catch (err) {
        if (mine !== otherTicket) return;
        compare.value = state.other ? state.other.id : "";
        say(`${tr.dataset.row}: ${err.message}`);
      }
    }

    function activate(tr, second) {
      if (second && state.row) setOther(tr);
      else open(tr);
    }
    for (const tr of allRows) {
      tr.tabIndex = 0;
      tr.classList.add("iv-row");
      tr.addEventListener("click", (e) => {
        if (e.target.closest("a")) return;
        activate(tr, e.ctrlKey || e.metaKey || e.shiftKey);
      });
      tr.addEventListener("keydown", (e) => {
        if (e.key === "Enter") activate(tr, e.ctrlKey || e.metaKey || e.shiftKey);
      });
    }
  }

  function init() {
    for (const t of document.querySelectorAll("table.sortable")) makeSortable(t);
    const table = document.getElementById("rows");
    const root = document.getElementById("viewer");
    if (table) makeFilters(table);
    if (table && root) makeViewer(root, table);
    document.documentElement.dataset.viewerReady = "true";
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", init);
  else init();
})();
