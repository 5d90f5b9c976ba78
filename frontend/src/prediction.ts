// The model's prediction of a run (GET /runs/{id}/prediction: the same controller,
// reference and start on the plant's model with ideal sensors, for a rig run the nominal
// linear model) drawn over the run, dotted, and the difference run − prediction in a plot
// of its own below it, sample k against sample k, growing with the run as its samples come
// in. The server's summary of the gap per channel is shown above that plot and asked again
// when the whole recording is in.
import { api, ApiError } from "./api";
import { fill, h } from "./dom";
import { channelColor, LivePlot, type LiveTrace } from "./plot";
import type { PlantDetail, PredictionStep, RunPrediction, StepInfoOut } from "./protocol.gen";
import { SampleRing } from "./series";
import { display, fmt, quantity } from "./units";

const REFRESH_MS = 300;
const REFRESH_TRIES = 20;

/** The ring channel holding run − prediction of a channel. */
export const diffName = (name: string): string => `d_${name}`;

/** The predicted columns and, sample by sample as the run's samples come in, the run
 * minus the prediction, in a ring sized to the prediction. */
export class PredictionSeries {
  readonly ring: SampleRing;
  readonly names: string[];
  private readonly values: Record<string, Float32Array> = {};

  constructor(
    readonly prediction: RunPrediction,
    /** the run's recorded channels */
    recorded: string[],
  ) {
    this.names = prediction.channels.map((c) => c.name).filter((n) => recorded.includes(n));
    for (const c of prediction.channels) this.values[c.name] = Float32Array.from(c.values);
    this.ring = new SampleRing([...this.names, ...this.names.map(diffName)], Math.max(1, prediction.n));
  }

  /** Bring the ring up to the samples `run` holds (as far as the prediction goes); true
   * when anything changed. */
  follow(run: SampleRing): boolean {
    if (run.end < this.ring.end) {
      this.ring.truncate(run.end); // the run's recording ended short of what was streamed
      return true;
    }
    const end = Math.min(run.end, this.prediction.n);
    const k0 = Math.max(this.ring.end, run.start);
    if (end <= k0) return false;
    const n = end - k0;
    const cols: Record<string, Float32Array> = {};
    for (const name of this.names) {
      const predicted = this.values[name].subarray(k0, end);
      const diff = new Float32Array(n);
      for (let i = 0; i < n; i++) diff[i] = run.at(name, k0 + i) - predicted[i];
      cols[name] = predicted;
      cols[diffName(name)] = diff;
    }
    this.ring.push(k0, n, cols);
    return true;
  }
}

/** "θ: RMS 2.01°, largest 5.3° at t = 1.02 s" for each channel compared. */
export function gapText(p: RunPrediction, plant: PlantDetail): string {
  const label = (name: string) => (name === "u" ? "u" : plant.outputs.find((o) => o.name === name)?.label ?? name);
  const order = (name: string) => (name === "u" ? plant.outputs.length : plant.outputs.findIndex((o) => o.name === name));
  const parts = [...p.gaps].sort((a, b) => order(a.name) - order(b.name)).map((g) => `${label(g.name)}: RMS ${quantity(g.rms, g.unit, 3)}, largest ${quantity(g.max_abs, g.unit, 3)} at t = ${fmt(g.t_max, 3)} s`);
  return `Run − prediction over ${p.compared.toLocaleString("en")} samples: ${parts.join(" · ")}`;
}

/** Steps shown in the table at most (the API gives the first 20). */
export const STEPS_SHOWN = 5;

type Characteristic = { name: string; title: string; value: (i: StepInfoOut, unit: string) => number | null; show: (x: number | null, unit: string) => string };

/** What the table compares, as the design page names it (times from the step). */
const CHARACTERISTICS: Characteristic[] = [
  { name: "overshoot", title: "past the final value, in % of the change", value: (i) => i.overshoot, show: (x) => (x === null ? "—" : `${fmt(x, 3)} %`) },
  { name: "rise time", title: "from 10 % to 90 % of the change", value: (i) => i.rise_time, show: (x) => (x === null ? "—" : `${fmt(x, 3)} s`) },
  { name: "settling (2 %)", title: "until it stays within 2 % of the change; — : not settled within the step", value: (i) => i.settling_time, show: (x) => (x === null ? "not settled" : `${fmt(x, 3)} s`) },
  { name: "error at the end", title: "target − final value", value: (i) => i.steady_state_error, show: (x, unit) => quantity(x, unit, 3) },
];

/** "t = 2 s: 30° → −30°" */
export function stepName(st: PredictionStep): string {
  return `t = ${fmt(st.t, 4)} s: ${quantity(st.start, st.unit, 3)} → ${quantity(st.target, st.unit, 3)}`;
}

/** The run's step characteristics beside the prediction's, a row per step (the first
 * {@link STEPS_SHOWN}), each cell "run / model (run − model)". */
export function stepTable(p: RunPrediction, plant: PlantDetail): HTMLElement | null {
  if (!p.steps.length) return null;
  const label = plant.outputs.find((o) => o.name === p.steps[0].output)?.label ?? p.steps[0].output;
  const cell = (c: Characteristic, st: PredictionStep) => {
    const run = st.run ? c.value(st.run, st.unit) : null;
    const model = st.prediction ? c.value(st.prediction, st.unit) : null;
    const diff = run !== null && model !== null ? c.show(run - model, st.unit).replace(/^(?!-|—)/, "+") : "";
    return h("td", { "data-characteristic": c.name }, h("span.run", c.show(run, st.unit)), " / ", h("span.model", c.show(model, st.unit)), diff ? h("span.diff", ` (${diff})`) : "");
  };
  const rows = p.steps.slice(0, STEPS_SHOWN).map((st) => h("tr", h("th", { scope: "row" }, stepName(st)), ...CHARACTERISTICS.map((c) => cell(c, st))));
  const more = p.steps.length - STEPS_SHOWN;
  return h(
    "div.step-compare",
    // scrolls sideways on a narrow screen: reachable by keyboard, named for a screen reader
    { "data-testid": "prediction-steps", tabindex: "0", role: "region", "aria-label": "steps of the reference, run against the model" },
    h("table", h("caption", `Steps of the reference: ${label}, run / model (run − model)`), h("thead", h("tr", h("th", { scope: "col" }, "step"), ...CHARACTERISTICS.map((c) => h("th", { scope: "col", title: c.title }, c.name)))), h("tbody", ...rows)),
    more > 0 ? h("p.note", `…and ${more} more step${more === 1 ? "" : "s"} (GET /runs/{id}/prediction lists the first 20).`) : "",
  );
}

export class PredictionView {
  readonly root: HTMLElement;
  readonly series: PredictionSeries;
  readonly plot: LivePlot;
  private readonly summary = h("p.prediction-gap", { "data-testid": "prediction-gap", "aria-live": "polite" });
  private readonly notes = h("ul.prediction-notes");
  private readonly steps = h("div.prediction-steps");
  private readonly message = h("p.error", { role: "alert" });
  private closed = false;
  private readonly plotDiv = h("div.diff-plot", { "data-testid": "prediction-diff", role: "figure", "aria-label": "run minus prediction" });

  constructor(
    prediction: RunPrediction,
    private readonly plant: PlantDetail,
    recorded: string[],
    outputs: string[],
    window: number | null,
  ) {
    this.series = new PredictionSeries(prediction, recorded);
    const colours = plant.outputs.map((o) => o.name);
    const traces: LiveTrace[] = plant.outputs
      .filter((o) => outputs.includes(o.name) && this.series.names.includes(o.name))
      .map((o) => ({ channel: diffName(o.name), label: `${o.label}: run − prediction`, axis: 1, scale: display(o.unit).scale, color: channelColor(o.name, colours) }));
    if (this.series.names.includes("u")) traces.push({ channel: diffName("u"), label: "u: run − prediction", axis: 2, scale: 1, color: channelColor("u", colours) });
    const units = [...new Set(plant.outputs.map((o) => display(o.unit).unit))].join(", ");
    this.plot = new LivePlot(this.plotDiv, this.series.ring, traces, { Ts: prediction.Ts, window, yTitles: [`run − prediction (${units})`, `Δu (${plant.inputs[0]?.unit ?? "V"})`] });
    this.root = h(
      "section.prediction",
      { "data-testid": "prediction" },
      h("h3", "Run against the model's prediction"),
      h("p.note", "Dotted in the plot above: ", prediction.model, "."),
      this.summary,
      this.steps,
      this.notes,
      this.message,
      this.plotDiv,
    );
    this.update(prediction);
  }

  /** The predicted outputs and u as dotted traces over the run (the run's colours). */
  traces(outputs: string[]): LiveTrace[] {
    const ring = this.series.ring;
    const out: LiveTrace[] = this.plant.outputs
      .filter((o) => outputs.includes(o.name) && this.series.names.includes(o.name))
      .map((o) => ({ channel: o.name, label: `${o.label}, predicted`, axis: 1, scale: display(o.unit).scale, dash: "dot" as const, ring }));
    if (this.series.names.includes("u")) out.push({ channel: "u", label: "u, predicted", axis: 2, scale: 1, dash: "dot", ring });
    return out;
  }

  /** The server's summary of the gap, and what the prediction leaves out. */
  update(p: RunPrediction): void {
    fill(this.summary, p.compared ? gapText(p, this.plant) : "The run has no samples to compare yet.");
    const table = stepTable(p, this.plant);
    fill(this.steps, ...(table ? [table] : []));
    const notes = [...p.notes];
    if (p.diverged_at !== null) notes.unshift(`The predicted loop ends at t = ${fmt(p.diverged_at, 3)} s: it diverges there (or the controller failed).`);
    if (p.replayed) notes.push(`${p.replayed} live change${p.replayed === 1 ? "" : "s"} of gains or reference replayed at the sample each took effect.`);
    fill(this.notes, ...notes.map((n) => h("li", n)));
  }

  /** Ask the server again once the whole recording is in, until its summary covers the
   * `recorded` samples (the store takes up to a quarter of a second after the stream). */
  async refresh(runId: string, recorded: number): Promise<void> {
    for (let i = 0; i < REFRESH_TRIES && !this.closed; i++) {
      if (i) await new Promise((resolve) => setTimeout(resolve, REFRESH_MS));
      try {
        const p = await api.prediction(runId);
        if (this.closed) return;
        this.update(p);
        if (p.compared >= Math.min(recorded, p.n)) return;
      } catch (err) {
        fill(this.message, err instanceof ApiError ? err.message : String(err));
        return;
      }
    }
  }

  destroy(): void {
    this.closed = true;
    this.plot.destroy();
  }
}
