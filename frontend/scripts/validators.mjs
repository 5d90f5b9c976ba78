// The wire checks the app runs (src/wire.ts) as plain code, compiled here by Ajv's
// standalone mode: Ajv compiling in the browser evaluates strings as JavaScript, which
// the lab's Content-Security-Policy (script-src 'self') forbids.
import Ajv2020, { _ } from "ajv/dist/2020.js";
import standaloneCode from "ajv/dist/standalone/index.js";

/** The definitions the app checks on arrival (a new one: add it here, then make protocol). */
const CHECKED = ["ServerMessage", "IdentLine"];
const ID = "https://elab.invalid/elab.v1";

/** The schema as Ajv checks decoded msgpack: a `bin` (JSON Schema: a string of format
 * binary) arrives as a Uint8Array; Ajv's discriminator takes no `mapping`. */
function forMsgpack(node) {
  if (Array.isArray(node)) return node.map(forMsgpack);
  if (node === null || typeof node !== "object") return node;
  const out = Object.fromEntries(Object.entries(node).map(([k, v]) => [k, forMsgpack(v)]));
  if (out.type === "string" && out.format === "binary") return { binary: true };
  if (typeof out.discriminator === "object" && out.discriminator !== null) {
    out.discriminator = { propertyName: out.discriminator.propertyName };
  }
  return out;
}

/** [the ES module of validators, its type declarations] for the wire schema. */
export function validators(schema, banner) {
  const ajv = new Ajv2020({ discriminator: true, strict: false, code: { source: true, esm: true } });
  ajv.addKeyword({ keyword: "binary", code: (cxt) => cxt.fail(_`!(${cxt.data} instanceof Uint8Array)`) });
  ajv.addSchema(forMsgpack({ ...schema, $id: ID }));
  const code = standaloneCode(ajv, Object.fromEntries(CHECKED.map((n) => [`validate${n}`, `${ID}#/$defs/${n}`])));
  if (code.includes("require(")) {
    throw new Error("a checked definition needs an Ajv runtime helper (require(...)), which an ES module cannot load: import it in validators.mjs");
  }
  const dts = [
    banner,
    `import type { ${CHECKED.join(", ")} } from "./protocol.gen";`,
    "",
    "export interface Validate<T> {",
    "  (data: unknown): data is T;",
    "  errors?: { instancePath: string; message?: string }[] | null;",
    "}",
    ...CHECKED.map((n) => `export declare const validate${n}: Validate<${n}>;`),
    "",
  ].join("\n");
  return [`${banner}\n${code}\n`, dts];
}
