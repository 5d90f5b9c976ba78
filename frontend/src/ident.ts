// Identification helpers without DOM: the model list in the CLI's syntax
// (`arx:4,4,3; n4sid:4`), uploaded files as request records, the data set in words, and
// the hand-over of an identified model to the design view.
import type { ArmaxSpec, ArxSpec, FileData, IdentDataOut, IdentOut, N4SidSpec, OeSpec } from "./protocol.gen";
import { fmt } from "./units";

export type ModelSpec = ArxSpec | ArmaxSpec | OeSpec | N4SidSpec;
export type ParsedModels = { ok: true; models: ModelSpec[] } | { ok: false; message: string };

const ORDERS: Record<string, { names: string[]; min: number[]; optional?: number }> = {
  arx: { names: ["na", "nb", "nk"], min: [0, 1, 0] },
  armax: { names: ["na", "nb", "nc", "nk"], min: [0, 1, 1, 0] },
  oe: { names: ["nb", "nf", "nk"], min: [1, 1, 0] },
  n4sid: { names: ["order", "horizon"], min: [0, 0], optional: 0 },
};
const MAX_ORDER = 50;

/** `arx:4,4,3; armax:2,2,2,3; oe:2,2,3; n4sid:4,16; n4sid` (order 0: chosen by the server). */
export function parseModels(text: string): ParsedModels {
  const models: ModelSpec[] = [];
  for (const raw of text.split(/[;\n]/)) {
    const item = raw.trim();
    if (!item) continue;
    const [kind, rest = ""] = item.split(":", 2).map((s) => s.trim());
    const spec = ORDERS[kind];
    if (!spec) return { ok: false, message: `“${item}”: the kind must be arx, armax, oe or n4sid` };
    const parts = rest ? rest.split(",").map((s) => s.trim()) : [];
    const need = spec.names.length;
    if (parts.length !== need && !(spec.optional !== undefined && parts.length <= need)) {
      return { ok: false, message: `“${item}”: write ${kind}:${spec.names.join(",")}` };
    }
    const values: Record<string, number> = {};
    for (let i = 0; i < need; i++) {
      const p = parts[i] ?? "0";
      if (!/^\d+$/.test(p)) return { ok: false, message: `“${item}”: ${spec.names[i]} must be a whole number (got “${p}”)` };
      const v = Number(p);
      if (v < spec.min[i] || v > (spec.names[i] === "horizon" ? 100 : MAX_ORDER)) {
        return { ok: false, message: `“${item}”: ${spec.names[i]} must be in ${spec.min[i]} … ${spec.names[i] === "horizon" ? 100 : MAX_ORDER}` };
      }
      values[spec.names[i]] = v;
    }
    models.push({ kind, ...values } as ModelSpec);
  }
  if (models.length > 10) return { ok: false, message: "at most 10 models at once" };
  return { ok: true, models };
}

/** The body's limit (the server's ELAB_MAX_UPLOAD default): every file of a request together. */
export const MAX_UPLOAD = 16 << 20;

/** "c1, c2" → ["c1", "c2"] (a column list as typed). */
export function columnNames(text: string): FileData["input"] {
  return text
    .split(",")
    .map((x) => x.trim())
    .filter(Boolean) as FileData["input"];
}

/** An uploaded file as a request record (`data` or `validation`): JSON by its extension,
 * else CSV or whitespace-separated columns; `Ts` null: from the file. */
export function fileRecord(name: string, text: string, input: FileData["input"], output: FileData["output"], Ts: number | null): FileData {
  return { source: "file", name, format: name.toLowerCase().endsWith(".json") ? "json" : "csv", text, input, output, Ts };
}

/** Why these files cannot go in one request (null: they can). */
export function tooLarge(files: { name: string; size: number }[], limit = MAX_UPLOAD): string | null {
  const total = files.reduce((n, f) => n + f.size, 0);
  if (total <= limit) return null;
  const mib = (n: number) => `${(n / 2 ** 20).toFixed(1)} MiB`;
  const which = files.length > 1 ? `${files.map((f) => f.name).join(" and ")} are ${mib(total)} together` : `${files[0].name} is ${mib(total)}`;
  return `${which}: the limit is ${mib(limit)}.`;
}

/** The data set as analysed, in a sentence: how many samples, which estimate and which
 * validate (the rest of the data, or a separate record), and how they were detrended. */
export function dataSummary(d: IdentDataOut, validationName: string | null = null): string {
  const n = (k: number) => k.toLocaleString("en");
  const split = d.estimation * d.Ts + d.t[0];
  const head = `${n(d.N)} samples at Ts = ${fmt(d.Ts * 1000)} ms`;
  if (d.validation === "split") return `${head}; estimation: the first ${n(d.estimation)} (to t = ${fmt(split)} s), validation: the rest; detrended: ${d.trend}.`;
  const record = validationName ? `the separate record ${validationName}` : "a separate record";
  const trend = d.trend === "mean" ? "the estimation data's means removed from both" : d.trend === "linear" ? "each record's own straight line removed" : "kept as recorded";
  return `${head}; estimation: all ${n(d.estimation)} of the data, validation: the ${n(d.N - d.estimation)} of ${record} (drawn after them, from t = ${fmt(split)} s); ${trend}.`;
}

/** What the design view receives from "Use this model". */
export interface HandedModel {
  name: string;
  source: string;
  Ts: number;
  input: string;
  output: string[];
  units: string[];
  fit: (number | null)[];
  ss: { A: number[][]; B: number[][]; C: number[][]; D: number[][] };
  tf: { num: number[]; den: number[] }[][];
  poles: number[][];
}

export function handOver(plantId: string, out: IdentOut, index: number, source: string): HandedModel {
  const m = out.models[index];
  const d = out.data;
  const model: HandedModel = {
    name: m.name,
    source,
    Ts: d.Ts,
    input: d.input_names[0],
    output: d.output_names,
    units: d.output_units,
    fit: m.fit.headline,
    ss: m.ss,
    tf: m.tf,
    poles: m.poles,
  };
  sessionStorage.setItem(`elab.model.${plantId}`, JSON.stringify(model));
  return model;
}

export function handedModel(plantId: string): HandedModel | null {
  const text = sessionStorage.getItem(`elab.model.${plantId}`);
  if (!text) return null;
  try {
    return JSON.parse(text) as HandedModel;
  } catch {
    return null;
  }
}

/** Step response of a discrete state space (x₀ = 0), `n` samples, every output. */
export function discreteStep(ss: HandedModel["ss"], n: number): number[][] {
  const nx = ss.A.length;
  const ny = ss.C.length;
  let x = new Array<number>(nx).fill(0);
  const y: number[][] = Array.from({ length: ny }, () => []);
  for (let k = 0; k < n; k++) {
    for (let i = 0; i < ny; i++) {
      let s = ss.D[i][0];
      for (let j = 0; j < nx; j++) s += ss.C[i][j] * x[j];
      y[i].push(s);
    }
    const next = new Array<number>(nx).fill(0);
    for (let i = 0; i < nx; i++) {
      let s = ss.B[i][0];
      for (let j = 0; j < nx; j++) s += ss.A[i][j] * x[j];
      next[i] = s;
    }
    x = next;
  }
  return y;
}
