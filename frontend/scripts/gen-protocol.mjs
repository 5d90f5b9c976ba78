// Generate src/protocol.gen.ts (the types) and src/wire.validate.gen.js (the checks, with
// their .d.ts) from ../shared/elab.v1.schema.json (written from the backend's pydantic
// models by scripts/wire_schema.py). `--check` exits 1 when a committed file differs
// from what the schema gives (tests/unit/test_wire_schema.py).
import { existsSync, readFileSync, writeFileSync } from "node:fs";
import { dirname, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import { compile } from "json-schema-to-typescript";
import { validators } from "./validators.mjs";

const here = dirname(fileURLToPath(import.meta.url));
const schemaPath = resolve(here, "../../shared/elab.v1.schema.json");

/** msgpack `bin` (JSON Schema: string, format binary) arrives as a Uint8Array. */
function binaryAsBytes(node) {
  if (Array.isArray(node)) return node.map(binaryAsBytes);
  if (node === null || typeof node !== "object") return node;
  const out = Object.fromEntries(Object.entries(node).map(([k, v]) => [k, binaryAsBytes(v)]));
  if (out.type === "string" && out.format === "binary") out.tsType = "Uint8Array";
  return out;
}

/** Property titles would each become a type alias (Kind1, Kind2, ...): keep model titles only. */
function dropPropertyTitles(node, isModel = false) {
  if (Array.isArray(node)) return node.map((n) => dropPropertyTitles(n));
  if (node === null || typeof node !== "object") return node;
  const out = {};
  for (const [k, v] of Object.entries(node)) {
    if (k === "title" && !isModel) continue;
    out[k] = k === "$defs" || k === "properties"
      ? Object.fromEntries(Object.entries(v).map(([n, d]) => [n, dropPropertyTitles(d, k === "$defs")]))
      : dropPropertyTitles(v);
  }
  return out;
}

const wire = JSON.parse(readFileSync(schemaPath, "utf8"));
const schema = dropPropertyTitles(binaryAsBytes(wire));
// A model used both ways has two definitions: `X-Input` (what a client sends, defaults
// optional) becomes X and `X-Output` (what the server sends, every field present) XOut.
for (const [key, def] of Object.entries(schema.$defs)) {
  def.title = key.replace(/-Input$/, "").replace(/-Output$/, "Out");
}
// One root whose properties name every definition, so each becomes an exported type.
const root = {
  title: "ElabProtocol",
  type: "object",
  additionalProperties: false,
  properties: Object.fromEntries(Object.keys(schema.$defs).map((k) => [k, { $ref: `#/$defs/${k}` }])),
  $defs: schema.$defs,
};
const banner = `/* Generated from shared/elab.v1.schema.json by scripts/gen-protocol.mjs (make protocol).
 * Do not edit: change the pydantic models in backend/elab/api/schemas/ instead. */`;
const ts = await compile(root, "ElabProtocol", {
  bannerComment: banner,
  additionalProperties: false,
  unreachableDefinitions: true,
  maxItems: 2, // pairs such as [lowest, highest] become tuples; longer limits stay arrays
  style: { singleQuote: false, printWidth: 100 },
});

const [checks, checksTypes] = validators(wire, banner);
const files = { "protocol.gen.ts": ts, "wire.validate.gen.js": checks, "wire.validate.gen.d.ts": checksTypes };

const check = process.argv.includes("--check");
let stale = false;
for (const [name, text] of Object.entries(files)) {
  const path = resolve(here, "../src", name);
  if (!check) {
    writeFileSync(path, text);
    console.log(`wrote frontend/src/${name}`);
  } else if (!existsSync(path) || readFileSync(path, "utf8") !== text) {
    console.error(`frontend/src/${name} is out of date: run \`make protocol\``);
    stale = true;
  }
}
if (stale) process.exit(1);
if (check) console.log("the generated protocol files are current");
