// What both engine modules share: the canvas, the WebGL 2 checks, timing and the readback packing.

/** The browser lacks something an engine needs (the driver exits 3). */
export class EngineMissing extends Error {}

/** A canvas of exactly width x height device pixels (pixel ratio 1), with a WebGL 2 context the engine
 *  will reuse; EngineMissing when WebGL 2 or float colour buffers are absent. */
export function makeCanvas(width, height) {
  const canvas = document.createElement("canvas");
  canvas.width = width;
  canvas.height = height;
  canvas.style.width = `${width}px`;
  canvas.style.height = `${height}px`;
  document.body.appendChild(canvas);
  const gl = canvas.getContext("webgl2", { antialias: false, preserveDrawingBuffer: true, alpha: true, premultipliedAlpha: false });
  if (!gl) throw new EngineMissing("WebGL 2 is not available in this Chromium (SwiftShader/ANGLE disabled?)");
  if (!gl.getExtension("EXT_color_buffer_float")) throw new EngineMissing("WebGL 2 lacks EXT_color_buffer_float: no float render targets");
  return { canvas, gl, renderer: `${gl.getParameter(gl.VERSION)}; ${rendererName(gl)}` };
}

function rendererName(gl) {
  const ext = gl.getExtension("WEBGL_debug_renderer_info");
  return ext ? gl.getParameter(ext.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
}

/** Wait until the GPU has finished: a one-pixel readback of the bound framebuffer is a full round trip. */
export function sync(gl) {
  const px = new Float32Array(4);
  gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.FLOAT, px);
}

export function median(xs) {
  const s = [...xs].sort((a, b) => a - b);
  const n = s.length;
  return n === 0 ? NaN : n % 2 ? s[(n - 1) / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
}

/** Time `frame()` over `frames` runs after `warmup` untimed ones, each ended by `finish()`. */
export async function timeFrames(frame, finish, warmup, frames) {
  for (let i = 0; i < warmup; i++) { await frame(); finish(); }
  const ms = [];
  for (let i = 0; i < frames; i++) {
    const t0 = performance.now();
    await frame();
    finish();
    ms.push(performance.now() - t0);
  }
  return ms;
}

/** RGBA float rows bottom-first (GL) -> RGB float32 rows top-first, as base64 of little-endian bytes. */
export function packRgb(rgba, width, height) {
  const out = new Float32Array(width * height * 3);
  for (let y = 0; y < height; y++) {
    const src = (height - 1 - y) * width * 4;
    const dst = y * width * 3;
    for (let x = 0; x < width; x++) {
      out[dst + 3 * x] = rgba[src + 4 * x];
      out[dst + 3 * x + 1] = rgba[src + 4 * x + 1];
      out[dst + 3 * x + 2] = rgba[src + 4 * x + 2];
    }
  }
  const bytes = new Uint8Array(out.buffer);
  let s = "";
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}
