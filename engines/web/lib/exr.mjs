// A minimal OpenEXR writer: one part, scanline, no compression, float32 B, G, R channels.
// Layout from the OpenEXR file-layout document (openexr.com, "OpenEXR File Layout"): magic 20000630,
// version 2, the header as (name\0 type\0 size:int32 value) attributes ended by a zero byte, the line
// offset table (one uint64 per block; one scanline per block without compression), then each block as
// y:int32, byte count:int32 and the scanline's channels one after another in the header's (alphabetical) order.
import { writeFileSync, renameSync } from "node:fs";

function attribute(name, type, value) {
  const head = Buffer.from(`${name}\0${type}\0`, "latin1");
  const size = Buffer.alloc(4);
  size.writeInt32LE(value.length);
  return Buffer.concat([head, size, value]);
}

function int32s(...values) {
  const b = Buffer.alloc(4 * values.length);
  values.forEach((v, i) => b.writeInt32LE(v, 4 * i));
  return b;
}

function float32s(...values) {
  const b = Buffer.alloc(4 * values.length);
  values.forEach((v, i) => b.writeFloatLE(v, 4 * i));
  return b;
}

/** The bytes of an EXR holding `rgb` (Float32Array, width*height*3, row 0 at the top). */
export function encodeExr(rgb, width, height) {
  if (rgb.length !== width * height * 3) throw new Error(`encodeExr: ${rgb.length} values for ${width}x${height}x3`);
  const names = ["B", "G", "R"]; // chlist is sorted by name
  const chlist = Buffer.concat([
    ...names.map((n) => Buffer.concat([Buffer.from(`${n}\0`, "latin1"), int32s(2 /* FLOAT */, 0 /* pLinear + reserved */, 1, 1)])),
    Buffer.from([0]),
  ]);
  const header = Buffer.concat([
    Buffer.from([0x76, 0x2f, 0x31, 0x01]), int32s(2),
    attribute("channels", "chlist", chlist),
    attribute("compression", "compression", Buffer.from([0])),
    attribute("dataWindow", "box2i", int32s(0, 0, width - 1, height - 1)),
    attribute("displayWindow", "box2i", int32s(0, 0, width - 1, height - 1)),
    attribute("lineOrder", "lineOrder", Buffer.from([0])), // INCREASING_Y: the top row first
    attribute("pixelAspectRatio", "float", float32s(1)),
    attribute("screenWindowCenter", "v2f", float32s(0, 0)),
    attribute("screenWindowWidth", "float", float32s(1)),
    Buffer.from([0]),
  ]);
  const lineBytes = width * 3 * 4;
  const blockBytes = 8 + lineBytes;
  const table = Buffer.alloc(8 * height);
  const body = Buffer.alloc(blockBytes * height);
  const start = header.length + table.length;
  for (let y = 0; y < height; y++) {
    table.writeBigUInt64LE(BigInt(start + y * blockBytes), 8 * y);
    let o = y * blockBytes;
    body.writeInt32LE(y, o);
    body.writeInt32LE(lineBytes, o + 4);
    o += 8;
    for (const c of [2, 1, 0]) { // B, G, R
      for (let x = 0; x < width; x++, o += 4) body.writeFloatLE(rgb[3 * (y * width + x) + c], o);
    }
  }
  return Buffer.concat([header, table, body]);
}

/** Write atomically: a temporary file beside the target, renamed over it. */
export function writeExr(path, rgb, width, height) {
  const tmp = `${path}.tmp${process.pid}`;
  writeFileSync(tmp, encodeExr(rgb, width, height));
  renameSync(tmp, path);
}
