// Reads an iblcheck export's sidecar (iblcheck-export.json) and checks the fields the engines use.
// Every problem is a SceneError naming the file, the key and the value (the driver exits 2 with it).
import { readFileSync, existsSync } from "node:fs";
import { dirname, resolve } from "node:path";

export class SceneError extends Error {}

function get(obj, path, file) {
  let v = obj;
  for (const k of path.split(".")) {
    if (v === null || typeof v !== "object" || !(k in v)) throw new SceneError(`${file}: key ${path} is missing`);
    v = v[k];
  }
  return v;
}

function number(obj, path, file, { min = -Infinity, max = Infinity, positive = false } = {}) {
  const v = get(obj, path, file);
  if (typeof v !== "number" || !Number.isFinite(v) || v < min || v > max || (positive && v <= 0)) {
    throw new SceneError(`${file}: ${path} = ${JSON.stringify(v)} must be a finite number` +
      (positive ? " > 0" : "") + (Number.isFinite(min) || Number.isFinite(max) ? ` in [${min}, ${max}]` : ""));
  }
  return v;
}

function vec3(obj, path, file) {
  const v = get(obj, path, file);
  if (!Array.isArray(v) || v.length !== 3 || !v.every((x) => typeof x === "number" && Number.isFinite(x))) {
    throw new SceneError(`${file}: ${path} = ${JSON.stringify(v)} must be three finite numbers`);
  }
  return v;
}

function existing(folder, obj, path, file) {
  const name = get(obj, path, file);
  if (typeof name !== "string" || !name) throw new SceneError(`${file}: ${path} = ${JSON.stringify(name)} must be a file name`);
  const full = resolve(folder, name);
  if (!full.startsWith(folder)) throw new SceneError(`${file}: ${path} = ${JSON.stringify(name)} leaves the export folder`);
  if (!existsSync(full)) throw new SceneError(`${file}: ${path} = ${JSON.stringify(name)}: no such file ${full}`);
  return name;
}

/** The checked sidecar as the page needs it: file names relative to the export folder, numbers checked. */
export function readSidecar(file) {
  let raw;
  try {
    raw = readFileSync(file, "utf8");
  } catch (e) {
    throw new SceneError(`${file}: cannot read the sidecar (${e.code ?? e.message})`);
  }
  let s;
  try {
    s = JSON.parse(raw);
  } catch (e) {
    throw new SceneError(`${file}: not JSON (${e.message})`);
  }
  if (s?.format !== "iblcheck-export") throw new SceneError(`${file}: format = ${JSON.stringify(s?.format)} is not "iblcheck-export"`);
  if (s.version !== 1) throw new SceneError(`${file}: version = ${JSON.stringify(s.version)}; this bridge reads version 1`);
  const folder = resolve(dirname(file));
  const width = number(s, "image.width", file, { min: 1, max: 8192 });
  const height = number(s, "image.height", file, { min: 1, max: 8192 });
  if (!Number.isInteger(width) || !Number.isInteger(height)) throw new SceneError(`${file}: image.width/height = ${width}x${height} must be integers`);
  const exposure = s.image.exposure ?? 1.0;
  if (exposure !== 1.0) throw new SceneError(`${file}: image.exposure = ${JSON.stringify(exposure)}; the engines render radiance at exposure 1 only`);
  const near = number(s, "camera.znear", file, { positive: true });
  const far = number(s, "camera.zfar", file, { positive: true });
  if (far <= near) throw new SceneError(`${file}: camera.zfar = ${far} must exceed camera.znear = ${near}`);
  return {
    folder,
    gltf: existing(folder, s, "gltf", file),
    environment: {
      file: existing(folder, s, "environment.file", file),
      rotationYDeg: number(s, "environment.rotation_y_deg", file),
      intensity: number(s, "environment.intensity", file, { min: 0 }),
      width: number(s, "environment.width", file, { min: 1, max: 65536 }),
      height: number(s, "environment.height", file, { min: 1, max: 65536 }),
    },
    camera: {
      yfov: number(s, "camera.yfov", file, { positive: true, max: Math.PI }),
      near, far,
      position: vec3(s, "camera.position", file),
      target: vec3(s, "camera.target", file),
      up: vec3(s, "camera.up", file),
    },
    width, height,
    scene: s.scene ?? "",
  };
}
