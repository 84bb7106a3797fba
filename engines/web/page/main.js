// The page's entry: loads the engine module the URL names (?engine=threejs|babylon) and exposes
// window.iblcheckRender(config) for the Node driver (render.mjs). Errors carry a kind: "missing" when the
// browser lacks what the engine needs (WebGL 2, float render targets), "scene" otherwise.
import { EngineMissing } from "./common.js";

const name = new URLSearchParams(location.search).get("engine");
const modules = { threejs: "./threejs.js", babylon: "./babylon.js" };

window.iblcheckRender = async (config) => {
  try {
    const engine = await import(modules[name]);
    return { ok: true, ...(await engine.render(config)) };
  } catch (e) {
    return { ok: false, kind: e instanceof EngineMissing ? "missing" : "scene", message: String(e?.message ?? e), stack: String(e?.stack ?? "") };
  }
};
window.iblcheckReady = name in modules;
