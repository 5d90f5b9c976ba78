// A controller file as the page sends it (docs/controllers.md): the format from the file's
// extension, TOML, JSON and Python as UTF-8 text, .mat and .npz as base64. A file the server would
// refuse for its kind, size or encoding is refused here, before anything is sent.
import type { ControllerUpload } from "./protocol.gen";

export type ControllerFormat = ControllerUpload["format"];

export const FORMATS: readonly ControllerFormat[] = ["toml", "json", "mat", "npz", "py"];
/** The largest controller file the lab takes (bytes). */
export const MAX_FILE_BYTES = 64 * 1024;
/** The longest name the lab keeps for a controller. */
const MAX_NAME = 80;

/** A file the page does not send; the message says why and what is allowed. */
export class FileRefused extends Error {
  override name = "FileRefused";
}

/** "ctrl.TOML" → "toml", "pi.py" → "py"; null for a name without one of the five extensions. */
export function formatOf(filename: string): ControllerFormat | null {
  const dot = filename.lastIndexOf(".");
  if (dot < 0) return null;
  const ext = filename.slice(dot + 1).toLowerCase();
  return FORMATS.find((f) => f === ext) ?? null;
}

/** Bytes as base64 (standard alphabet, padded), built in chunks so a large file does not
 * overflow the call stack. */
export function base64(bytes: ArrayBuffer | Uint8Array): string {
  const u8 = bytes instanceof Uint8Array ? bytes : new Uint8Array(bytes);
  const CHUNK = 0x8000;
  let binary = "";
  for (let i = 0; i < u8.length; i += CHUNK) binary += String.fromCharCode(...u8.subarray(i, i + CHUNK));
  return btoa(binary);
}

/** 65 536 → "64 KiB", 65 537 → "64.1 KiB" (rounded up: a file over the limit never
 * reads as at it). */
export function kib(bytes: number): string {
  return `${Math.ceil((bytes / 1024) * 10) / 10} KiB`;
}

/**
 * The upload of `file` for `plant`, or FileRefused. A .mat or .npz file carries no name of
 * its own, so it is sent with its file name; a TOML or JSON file's `name` field names it.
 * A Python file is sent as text with its file name (its template's docstring, which the
 * server would take otherwise, is the same long sentence for every copy of it).
 */
export async function uploadOf(file: Pick<File, "name" | "size" | "arrayBuffer">, plant: string): Promise<ControllerUpload> {
  const format = formatOf(file.name);
  if (!format) throw new FileRefused(`${file.name}: not a controller file; allowed: .toml, .json, .mat, .npz or .py`);
  if (file.size > MAX_FILE_BYTES) throw new FileRefused(`${file.name} is ${kib(file.size)}: a controller file may be at most ${kib(MAX_FILE_BYTES)}. Nothing was sent.`);
  if (file.size === 0) throw new FileRefused(`${file.name} is empty. Nothing was sent.`);
  const bytes = await file.arrayBuffer();
  if (format === "mat" || format === "npz") return { plant, format, content: base64(bytes), name: file.name.slice(0, MAX_NAME) };
  let text: string;
  try {
    text = new TextDecoder("utf-8", { fatal: true }).decode(bytes);
  } catch {
    throw new FileRefused(`${file.name} is not UTF-8 text: save it as UTF-8 and upload it again. Nothing was sent.`);
  }
  return format === "py" ? { plant, format, content: text, name: file.name.slice(0, MAX_NAME) } : { plant, format, content: text };
}
