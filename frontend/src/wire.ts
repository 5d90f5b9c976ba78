// Every message the server sends is checked against the wire schema before the app acts
// on it: shared/elab.v1.schema.json, written from the server's pydantic models (make
// protocol), the same schema protocol.gen.ts is generated from. A server and an app of
// different versions then fail loudly at the edge, naming the field, instead of deep
// inside a view.
import Ajv2020, { type ValidateFunction } from "ajv/dist/2020";
import schema from "../../shared/elab.v1.schema.json";
import type { ServerMessage } from "./protocol.gen";

export class WireError extends Error {}

/** The schema as Ajv checks decoded msgpack: a `bin` (JSON Schema: a string of format
 * binary) arrives as a Uint8Array; Ajv's discriminator takes no `mapping`. */
function forMsgpack(node: unknown): unknown {
  if (Array.isArray(node)) return node.map(forMsgpack);
  if (node === null || typeof node !== "object") return node;
  const entries = Object.entries(node as Record<string, unknown>);
  const out: Record<string, unknown> = Object.fromEntries(entries.map(([k, v]) => [k, forMsgpack(v)]));
  if (out.type === "string" && out.format === "binary") return { binary: true };
  if (typeof out.discriminator === "object" && out.discriminator !== null) {
    out.discriminator = { propertyName: (out.discriminator as { propertyName: string }).propertyName };
  }
  return out;
}

const ajv = new Ajv2020({ discriminator: true, strict: false });
ajv.addKeyword({ keyword: "binary", validate: (_: unknown, data: unknown) => data instanceof Uint8Array });
ajv.addSchema(forMsgpack({ ...schema, $id: "https://elab.invalid/elab.v1" }) as object);

function validator<T>(definition: string): ValidateFunction<T> {
  const v = ajv.getSchema<T>(`https://elab.invalid/elab.v1#/$defs/${definition}`);
  if (!v) throw new WireError(`the wire schema has no ${definition}`);
  return v;
}

const isServerMessage = validator<ServerMessage>("ServerMessage");

/** A decoded server message, checked; WireError says what does not match. */
export function serverMessage(raw: unknown): ServerMessage {
  if (typeof raw !== "object" || raw === null || Array.isArray(raw)) throw new WireError(`not an elab.v1 message: ${JSON.stringify(raw)}`);
  if (isServerMessage(raw)) return raw;
  throw new WireError(`not an elab.v1 message: ${ajv.errorsText(isServerMessage.errors, { dataVar: "message" })}`);
}

/** A checker for any model of the schema (tests, and checking REST answers). */
export function check<T>(definition: string, raw: unknown): T {
  const v = validator<T>(definition);
  if (v(raw)) return raw;
  throw new WireError(`not an elab.v1 ${definition}: ${ajv.errorsText(v.errors, { dataVar: "data" })}`);
}
