// After `vite build`: each compressible asset also as `name.gz` (gzip level 9, made once
// here), which the server sends to a browser that takes gzip instead of compressing the
// file again at every request (backend/elab/api/assets.py). Written only where it saves at
// least a tenth; fonts in woff/woff2 are compressed already.
import { readdirSync, readFileSync, writeFileSync } from "node:fs";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";
import { gzipSync } from "node:zlib";

const assets = join(dirname(fileURLToPath(import.meta.url)), "../../backend/elab/api/static/assets");
for (const name of readdirSync(assets)) {
  if (!/\.(js|css|svg|ttf|json)$/.test(name)) continue;
  const raw = readFileSync(join(assets, name));
  const packed = gzipSync(raw, { level: 9 });
  if (packed.length <= 0.9 * raw.length) writeFileSync(join(assets, `${name}.gz`), packed);
}
