/* Generated from shared/elab.v1.schema.json by scripts/gen-protocol.mjs (make protocol).
 * Do not edit: change the pydantic models in backend/elab/api/schemas/ instead. */
import type { ServerMessage, IdentLine } from "./protocol.gen";

export interface Validate<T> {
  (data: unknown): data is T;
  errors?: { instancePath: string; message?: string }[] | null;
}
export declare const validateServerMessage: Validate<ServerMessage>;
export declare const validateIdentLine: Validate<IdentLine>;
