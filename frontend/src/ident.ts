// Identification helpers without DOM: the model list in the CLI's syntax
// (`arx:4,4,3; n4sid:4`), uploaded files as request records, the data set in words, and
// an identified model as the server keeps it for design.
import type { ArmaxSpec, ArxSpec, FileData, IdentDataOut, IdentModelOut, IdentOut, LinkSpec, ModelCreate, N4SidSpec, OeSpec } from "./protocol.gen";
import { fmt } from "./units";

export type ModelSpec = ArxSpec | ArmaxSpec | OeSpec | N4SidSpec | LinkSpec;
export type ParsedModels = { ok: true; models: ModelSpec[] } | { ok: false; message: string };

const ORDERS: Record<string, { names: string[]; min: number[]; optional?: number }> = {
  arx: { names: ["na", "nb", "nk"], min: [0, 1, 0] },
  armax: { names: ["na", "nb", "nc", "nk"], min: [0, 1, 1, 0] },
  oe: { names: ["nb", "nf", "nk"], min: [1, 1, 0] },
  n4sid: { names: ["order", "horizon"], min: [0, 0], optional: 0 },
  link: { names: [], min: [] },
};
const MAX_ORDER = 50;

/** `arx:4,4,3; armax:2,2,2,3; oe:2,2,3; n4sid:4,16; n4sid` (order 0: chosen by the server);
 * `link`: the flexible link's physics. */
export function parseModels(text: string): ParsedModels {
  const models: ModelSpec[] = [];
  for (const raw of text.split(/[;\n]/)) {
    const item = raw.trim();
    if (!item) continue;
    const [kind, rest = ""] = item.split(":", 2).map((s) => s.trim());
    const spec = ORDERS[kind];
    if (!spec) return { ok: false, message: `“${item}”: the kind must be arx, armax, oe, n4sid or link` };
    const parts = rest ? rest.split(",").map((s) => s.trim()) : [];
    const need = spec.names.length;
    if (parts.length !== need && !(spec.optional !== undefined && parts.length <= need)) {
      return { ok: false, message: need ? `“${item}”: write ${kind}:${spec.names.join(",")}` : `“${item}”: write ${kind} alone` };
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

/** "Use this model": the body of `POST /models` for model `index` of an identification's
 * result — its discrete state space, the data's names and units, where it came from and
 * its headline fit. The server keeps it and gives it an id and a design page to share. */
export function modelBody(plantId: string, out: IdentOut, index: number, source: string): ModelCreate {
  const m = out.models[index];
  const d = out.data;
  type Matrix = ModelCreate["A"];
  return {
    plant: plantId,
    name: m.name,
    Ts: d.Ts,
    A: m.ss.A as Matrix,
    B: m.ss.B as Matrix,
    C: m.ss.C as Matrix,
    D: m.ss.D as Matrix,
    input: { name: d.input_names[0], unit: d.input_units[0] ?? "" },
    outputs: d.output_names.map((name, i) => ({ name, unit: d.output_units[i] ?? "" })) as ModelCreate["outputs"],
    source: source.slice(0, 200),
    kind: m.kind,
    fit: m.fit.headline,
    verdicts: m.verdicts.map((v) => ({ topic: v.topic, level: v.level, finding: v.finding, advice: v.advice ?? null })),
  };
}

/** What each physical ratio of a link model is (docs/identification.md). */
export const LINK_PARAMETERS: [name: string, meaning: string, unit: string][] = [
  ["a", "K_s/J_eq: link stiffness over servo inertia", "1/s²"],
  ["b", "K_s/J_l: link stiffness over link inertia", "1/s²"],
  ["c", "B_eq/J_eq: servo viscous damping (with the back-EMF)", "1/s"],
  ["g", "k_u/J_eq: motor torque per volt over servo inertia", "1/(V s²)"],
  ["f", "τ_c/J_eq: Coulomb friction", "1/s²"],
  ["u_dead", "the motor's dead zone", "V"],
  ["beta", "B_l/J_eq: link damping over servo inertia", "1/s"],
  ["beta_l", "B_l/J_l: link damping over link inertia", "1/s"],
  ["sigma", "the strain gauge's true gain over its calibration", ""],
];

/** A link model's physical ratios as table rows: name, estimate ± standard deviation, meaning. */
export function linkRows(m: IdentModelOut): [string, string, string][] {
  const p = m.parameters as Record<string, number | null | Record<string, number | null>>;
  const std = (p.std ?? {}) as Record<string, number | null>;
  return LINK_PARAMETERS.map(([name, meaning, unit]) => [name, `${fmt(p[name] as number | null)} ± ${fmt(std[name], 2)}${unit ? " " + unit : ""}`, meaning]);
}
