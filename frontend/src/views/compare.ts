// Two runs of a plant side by side (/compare?runs=a,b): their outputs and input drawn
// together (the first solid, the second dashed), their settings and outcomes in two
// columns, and one CSV holding both, sample by sample.
import { api, type RecordingJson } from "../api";
import { csv, fill, h, link, saveText } from "../dom";
import { outcomeWords } from "../outcome";
import { chart, channelColor, type Series } from "../plot";
import type { PlantDetail, RunInfo } from "../protocol.gen";
import { runSettings } from "../settings";
import { display, fmt } from "../units";
import { failure, loading, pageHeader, plantDetail } from "./common";

/** The longest runs compared in the page (samples each); longer ones: their CSVs. */
export const MAX_SAMPLES = 200_000;

export type Recording = RecordingJson;

/** Why two runs cannot be compared, or null. */
export function refusal(a: RunInfo, b: RunInfo): string | null {
  if (a.id === b.id) return `both are run ${a.id}: choose two different runs`;
  if (a.plant !== b.plant) return `run ${a.id} is of ${a.plant} and run ${b.id} of ${b.plant}: compare runs of one plant`;
  if (Math.abs(a.Ts - b.Ts) > 1e-12 * a.Ts) return `run ${a.id} has a sample time of ${fmt(a.Ts * 1e3)} ms and run ${b.id} ${fmt(b.Ts * 1e3)} ms: compare runs of one sample time`;
  for (const r of [a, b]) if (r.n_samples > MAX_SAMPLES) return `run ${r.id} has ${r.n_samples.toLocaleString("en")} samples, more than the ${MAX_SAMPLES.toLocaleString("en")} this page compares: download its CSV`;
  return null;
}

/** Both recordings in one CSV: time, then each channel of the first run and of the second
 * ("a:theta (rad)", "b:theta (rad)"), sample k on row k (the shorter run's cells empty). */
export function bothCsv(a: RunInfo, ra: Recording, b: RunInfo, rb: Recording, channels: string[]): string {
  const n = Math.max(ra.t.length, rb.t.length);
  const t = Array.from({ length: n }, (_, k) => (k < ra.t.length ? ra.t[k] : rb.t[k]));
  const unit = (r: RunInfo, c: string) => r.channels.find((x) => x.name === c)?.unit ?? "";
  const header = ["t (s)", ...channels.map((c) => `a:${c} (${unit(a, c)})`), ...channels.map((c) => `b:${c} (${unit(b, c)})`)];
  const lines = [`# a: run ${a.id} (${a.status}); b: run ${b.id} (${b.status}); plant ${a.plant}; Ts ${a.Ts} s`, ""].join("\n");
  return lines + csv(header, [t, ...channels.map((c) => ra.data[c] ?? []), ...channels.map((c) => rb.data[c] ?? [])]);
}

export async function comparePage(root: HTMLElement, _params: Record<string, string>, query: URLSearchParams): Promise<void> {
  const ids = (query.get("runs") ?? "").split(",").map((s) => s.trim()).filter(Boolean);
  const body = h("div", loading());
  root.append(pageHeader("Compare two runs", [["/runs", "Runs"]], h("p.lead", "Two runs of one plant drawn together, their settings side by side, and one CSV of both.")), body);
  if (ids.length !== 2) return void fill(body, h("p.error", { role: "alert" }, `Give two runs: /compare?runs=<first>,<second> (${ids.length} given). Pick two in `, link("/runs", "Runs"), "."));
  let a: RunInfo, b: RunInfo, plant: PlantDetail;
  try {
    [a, b] = await Promise.all(ids.map((id) => api.run(id)));
    plant = await plantDetail(a.plant);
  } catch (err) {
    return void fill(body, failure(err));
  }
  const why = refusal(a, b);
  if (why) return void fill(body, h("p.error", { role: "alert", "data-testid": "compare-error" }, `These runs cannot be compared: ${why}.`));
  const channels = ["r", "u", ...plant.outputs.map((o) => o.name)].filter((c) => a.channels.some((x) => x.name === c) && b.channels.some((x) => x.name === c));
  let ra: Recording, rb: Recording;
  try {
    [ra, rb] = await Promise.all([api.recording(a.id, channels), api.recording(b.id, channels)]);
  } catch (err) {
    return void fill(body, failure(err));
  }
  const plotDiv = h("div.compare-plot", { "data-testid": "compare-plot" });
  const series: Series[] = [];
  const outputs = plant.outputs.map((o) => o.name);
  for (const [tag, run, rec, dash] of [["a", a, ra, "solid"], ["b", b, rb, "dash"]] as const) {
    for (const o of plant.outputs.filter((x) => channels.includes(x.name))) {
      const d = display(o.unit);
      series.push({ x: rec.t, y: (rec.data[o.name] ?? []).map((v) => (v === null ? null : v * d.scale)), name: `${tag}: ${o.label} (${run.id})`, dash, color: channelColor(o.name, outputs) });
    }
    series.push({ x: rec.t, y: rec.data.u ?? [], name: `${tag}: u (${run.id})`, axis: 2, dash, color: channelColor("u", outputs) });
  }
  const units = [...new Set(plant.outputs.map((o) => display(o.unit).unit))].join(", ");
  const save = h("button", { type: "button", "data-testid": "compare-csv", onclick: () => saveText(`compare-${a.id}-${b.id}.csv`, bothCsv(a, ra, b, rb, channels)) }, "CSV of both");
  const column = (tag: string, run: RunInfo) =>
    h(
      "section.panel.compare-column",
      { "data-compare": tag },
      h("h2", `${tag}: `, link(`/runs/${run.id}`, h("span.mono", run.id))),
      h("p", h("span.badge", { "data-state": run.status }, run.status), " ", run.experiment, " · ", run.mode, " · ", `${fmt(run.n_samples * run.Ts)} s`, run.outcome?.length ? h("span.outcome-words", ` · ⚠ ${outcomeWords(run.outcome)}`) : ""),
      h("table.settings", ...runSettings(run, plant).map((s) => h("tbody", h("tr", h("th", { colspan: 2, scope: "colgroup" }, s.title)), ...s.rows.map(([k, v]) => h("tr", h("td", k), h("td", v)))))),
    );
  fill(
    body,
    h("section.panel", h("div.toolbar", h("span", `${plant.name}: a solid, b dashed`), save), plotDiv),
    h("div.compare-columns", column("a", a), column("b", b)),
  );
  chart(plotDiv, series, { xTitle: "time t (s)", yTitles: [`outputs (${units})`, `u (${plant.inputs[0]?.unit ?? "V"})`] });
}
