// A static file server on 127.0.0.1 (a free port) so that the page can use ES modules and an import map:
// /engine/... is engines/web (node_modules included), /scene/... the export folder. Read-only, GET only,
// no directory listings, nothing outside the two roots.
import { createServer } from "node:http";
import { readFile } from "node:fs/promises";
import { resolve, sep, extname } from "node:path";

const TYPES = {
  ".html": "text/html", ".js": "text/javascript", ".mjs": "text/javascript", ".json": "application/json",
  ".gltf": "model/gltf+json", ".bin": "application/octet-stream", ".hdr": "application/octet-stream",
  ".wasm": "application/wasm",
};

function inside(root, rel) {
  const p = resolve(root, "." + sep + decodeURIComponent(rel));
  return p === root || p.startsWith(root + sep) ? p : null;
}

/** Serve {prefix: folder}; resolves to {server, url} once listening. */
export function serve(roots) {
  const table = Object.entries(roots).map(([prefix, dir]) => [`/${prefix}/`, resolve(dir)]);
  const server = createServer(async (req, res) => {
    const path = new URL(req.url, "http://127.0.0.1").pathname;
    const hit = table.find(([prefix]) => path.startsWith(prefix));
    const file = hit && req.method === "GET" ? inside(hit[1], path.slice(hit[0].length)) : null;
    try {
      if (!file) throw new Error("not served");
      const body = await readFile(file);
      res.writeHead(200, { "content-type": TYPES[extname(file)] ?? "application/octet-stream", "cache-control": "no-store" });
      res.end(body);
    } catch {
      res.writeHead(404, { "content-type": "text/plain" });
      res.end("not found");
    }
  });
  return new Promise((ok, fail) => {
    server.once("error", fail);
    server.listen(0, "127.0.0.1", () => ok({ server, url: `http://127.0.0.1:${server.address().port}` }));
  });
}
