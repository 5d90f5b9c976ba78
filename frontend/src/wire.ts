// Every message the server sends is checked against the wire schema before the app acts
// on it: shared/elab.v1.schema.json, written from the server's pydantic models (make
// protocol), the same schema protocol.gen.ts is generated from. A server and an app of
// different versions then fail loudly at the edge, naming the field, instead of deep
// inside a view. The checks are compiled ahead (wire.validate.gen.js, make protocol):
// the page's Content-Security-Policy allows no code made from strings at run time.
import type { IdentLine, ServerMessage } from "./protocol.gen";
import { type Validate, validateIdentLine, validateServerMessage } from "./wire.validate.gen.js";

export class WireError extends Error {}

function errorsText(v: Validate<unknown>, dataVar: string): string {
  return (v.errors ?? []).map((e) => `${dataVar}${e.instancePath} ${e.message ?? "is not valid"}`).join(", ");
}

/** A decoded server message, checked; WireError says what does not match. */
export function serverMessage(raw: unknown): ServerMessage {
  if (typeof raw !== "object" || raw === null || Array.isArray(raw)) throw new WireError(`not an elab.v1 message: ${JSON.stringify(raw)}`);
  if (validateServerMessage(raw)) return raw;
  throw new WireError(`not an elab.v1 message: ${errorsText(validateServerMessage, "message")}`);
}

/** A line of the identification stream, checked. */
export function identLine(raw: unknown): IdentLine {
  if (validateIdentLine(raw)) return raw;
  throw new WireError(`not an elab.v1 IdentLine: ${errorsText(validateIdentLine, "data")}`);
}
