// Identification runs: excite the plant (PRBS, sine or step) in closed loop with the
// predefined controller — or in open loop — record the response live, download it.
import { api } from "../api";
import { fill, h } from "../dom";
import { durationField, SignalForm, StartOptions } from "../experiment";
import { FieldSet } from "../forms";
import type { PlantDetail, RunCreate, RunInfo } from "../protocol.gen";
import { RunPanel } from "../runpanel";
import { display, fmt } from "../units";
import { errorText, experimentPage, showApiError } from "./common";
import { IdentAnalysis } from "./identanalysis";
import { RigModeChoice, type RunMode } from "./rigmode";

export function identificationPage(root: HTMLElement, params: Record<string, string>, query: URLSearchParams): Promise<() => void> {
  return experimentPage(root, params.id, "identification", (plant) => {
    const view = new IdentificationView(plant, query.get("run"));
    return { content: view.root, cleanup: () => view.destroy() };
  });
}

type Loop = "closed-input" | "closed-reference" | "open";

class IdentificationView {
  readonly root: HTMLElement;
  private excitation!: SignalForm;
  /** the reference the predefined controller tracks with the excitation at the input (the
   * chapter's experiment for the link model: a square of tens of degrees) */
  private reference: SignalForm | null = null;
  private readonly runFields = new FieldSet();
  private readonly startOptions = new StartOptions();
  private readonly where: RigModeChoice;
  private readonly loop: HTMLSelectElement;
  private readonly realistic = h("input", { type: "checkbox", id: "realistic-sensors", name: "realistic", checked: true });
  private readonly excitationSlot = h("div");
  private readonly formMsg = h("p.error", { role: "alert", "data-testid": "form-error" });
  private readonly runArea = h("div.run-area");
  private readonly handover = h("section.panel.handover", { hidden: true });
  private readonly analysisSlot = h("div");
  private readonly fileAnalysis: IdentAnalysis;
  private analysis: IdentAnalysis | null = null;
  private run: RunPanel | null = null;

  constructor(
    readonly plant: PlantDetail,
    runId: string | null,
  ) {
    this.loop = h(
      "select",
      { id: "loop", onchange: () => this.buildExcitation() },
      h("option", { value: "closed-input" }, "closed loop, excitation added to the control signal u"),
      h("option", { value: "closed-reference" }, "closed loop, excitation added to the reference"),
      h("option", { value: "open" }, "open loop: the excitation is the plant input"),
    );
    const duration = this.runFields.add(durationField(30, undefined, undefined, plant.Ts));
    this.where = new RigModeChoice(plant, "ident", (mode) => this.modeChanged(mode));
    this.buildExcitation();
    const form = h(
      "form.run-form.panel",
      { novalidate: true, "aria-label": "identification experiment", onsubmit: (ev: Event) => (ev.preventDefault(), void this.start()) },
      h("h2", "Experiment"),
      this.where.root,
      h("fieldset", h("legend", "Loop"), h("div.field", h("label", { for: "loop" }, "Configuration"), this.loop), h("small.hint", `The predefined controller (${plant.predefined_design}) keeps the plant near its operating point; open loop suits stable plants only.`)),
      this.excitationSlot,
      h("fieldset", h("legend", "Sensors"), h("label.check", this.realistic, " Realistic sensors"), h("small.hint", { id: "sensors-hint" }, `On: the outputs carry the plant's sensor noise (${sensorText(plant, plant.sensors.noise_std ?? [])}, white) and are rounded to its sensors' resolution (${sensorText(plant, plant.sensors.quantum ?? [])}), as a real experiment's would. Off: exact outputs. The download's header says which.`)),
      h("fieldset", h("legend", "Length"), h("div.grid", duration.root), this.startOptions.root),
      h("div.actions", h("button.primary", { type: "submit" }, "Start")),
      this.formMsg,
    );
    this.runArea.append(h("div.panel.empty", h("p", "Press Start: the excitation and the response draw here live; the recording downloads as CSV, JSON or MATLAB .mat.")));
    this.fileAnalysis = new IdentAnalysis(plant, { kind: "file" });
    const upload = h("details.panel.wide", h("summary", "Or identify from a data file (CSV, JSON, .dat — e.g. a recording made elsewhere)"), this.fileAnalysis.root);
    this.root = h("div", h("div.split", form, this.runArea), this.handover, this.analysisSlot, upload);
    if (runId) void api.run(runId).then((info) => this.showRun(info), (err) => fill(this.formMsg, String(err)));
  }

  /** An earlier run (?run=ID): its recording, ready for analysis. */
  private showRun(info: RunInfo): void {
    this.run?.destroy();
    this.run = new RunPanel(info, this.plant, { onState: (s) => this.onState(s) });
    fill(this.runArea, this.run.root);
  }

  private buildExcitation(): void {
    const loop = this.loop.value as Loop;
    const p = this.plant;
    const unit = loop === "closed-reference" ? (p.outputs.find((o) => o.name === p.reference_output)?.unit ?? "") : (p.inputs[0]?.unit ?? "V");
    const initial = loop === "closed-reference" ? { kind: "prbs" as const, amplitude: (5 * Math.PI) / 180, order: 10, band: 0.05, offset: 0 } : { kind: "prbs" as const, amplitude: 1, order: 10, band: 0.05, offset: 0 };
    this.excitation = new SignalForm("excitation", loop === "open" ? "Input signal" : "Excitation", ["prbs", "sine", "step"], unit, initial, undefined, undefined, p.Ts);
    const refUnit = p.outputs.find((o) => o.name === p.reference_output)?.unit ?? "";
    this.reference = loop === "closed-input" ? new SignalForm("signal", "Reference (what the controller tracks meanwhile)", ["step", "square"], refUnit, { kind: "step", amplitude: 0, offset: 0, t0: 0 }, undefined, undefined, p.Ts) : null;
    fill(this.excitationSlot, this.excitation.root, this.reference?.root ?? null);
  }

  private request(): RunCreate | null {
    const excitation = this.excitation.value();
    const v = this.runFields.values();
    const reference = this.reference ? this.reference.value() : { kind: "step" as const, amplitude: 0 };
    if (!excitation || !v || !reference) return null;
    const mode = this.where.mode;
    // the server's default for simulated identification: realistic; the rig's sensors are real
    const realistic = mode === "simulation" && this.realistic.checked;
    const sensors = mode === "rig" ? {} : { noise: realistic, quantize: realistic };
    const base = { plant: this.plant.id, mode, experiment: "identification" as const, duration: v.get("duration")!, pace: "realtime" as const, private: this.startOptions.private, ...sensors };
    const loop = this.loop.value as Loop;
    if (loop === "open") return { ...base, controller: { kind: "open_loop" }, signal: excitation };
    return { ...base, controller: { kind: "predefined" }, signal: reference, excitation, excitation_at: loop === "closed-input" ? "input" : "reference" };
  }

  private async start(): Promise<void> {
    fill(this.formMsg);
    const req = this.request();
    if (!req) {
      fill(this.formMsg, "Please correct the marked fields; nothing was sent.");
      return;
    }
    if (this.where.blocker()) return void fill(this.formMsg, "Nothing was sent: see the rig's steps above.");
    const previous = this.run;
    try {
      const info = await api.createRun(req);
      if (req.mode === "rig") this.where.started();
      this.run?.destroy();
      this.run = new RunPanel(info, this.plant, { onState: (s) => this.onState(s) });
      fill(this.runArea, this.run.root);
      this.handover.hidden = true;
      this.analysis?.destroy();
      this.analysis = null;
      fill(this.analysisSlot);
      history.replaceState(null, "", `${location.pathname}?run=${info.id}`);
    } catch (err) {
      showApiError(err, [this.excitation.fields, ...(this.reference ? [this.reference.fields] : []), this.runFields], this.formMsg);
      if (req.mode === "rig") this.where.refused(err);
      return;
    }
    await this.startOptions.retire(previous).catch((err: unknown) => fill(this.formMsg, `The previous run goes on: ${errorText(err)}`));
  }

  /** The rig's sensors are real: no simulated noise or quantisation to choose. */
  private modeChanged(mode: RunMode): void {
    this.realistic.disabled = mode === "rig";
    fill(this.formMsg);
  }

  private onState(state: string): void {
    if (!this.run || state === "running" || state === "paused" || state === "created") return;
    void api.run(this.run.run.id).then((info) => this.showHandover(info));
  }

  /** What the identification analysis takes over: the data set and where to get it. */
  private showHandover(run: RunInfo): void {
    const p = this.plant;
    this.handover.hidden = false;
    if (!this.analysis || this.analysis.source.kind !== "run" || this.analysis.source.runId !== run.id) {
      this.analysis?.destroy();
      this.analysis = new IdentAnalysis(p, { kind: "run", runId: run.id });
      fill(this.analysisSlot, this.analysis.root);
    }
    fill(
      this.handover,
      h("h2", "Data set"),
      h(
        "table.params",
        h(
          "tbody",
          h("tr", h("th", { scope: "row" }, "Samples"), h("td", `${run.n_samples.toLocaleString("en")} at Ts = ${fmt(run.Ts * 1000)} ms (${fmt(run.n_samples * run.Ts)} s), status ${run.status}`)),
          h("tr", h("th", { scope: "row" }, "Input"), h("td", `u (${p.inputs[0]?.unit ?? "V"}): the plant input, excitation included`)),
          h("tr", h("th", { scope: "row" }, "Outputs"), h("td", p.outputs.map((o) => `${o.name} (${o.unit})`).join(", "))),
          h("tr", h("th", { scope: "row" }, "Excitation"), h("td.mono", JSON.stringify(run.request.excitation ?? run.request.signal))),
          h("tr", h("th", { scope: "row" }, "Sensors"), h("td", { "data-testid": "sensors" }, sensorsUsed(p, run))),
        ),
      ),
      h("p", "Downloads: ", h("a", { href: `${run.data_url}?format=csv&channels=u,${p.outputs.map((o) => o.name).join(",")}`, download: `${run.id}-io.csv` }, "input and outputs (CSV)"), " · ", h("a", { href: `${run.data_url}?format=mat`, download: `${run.id}.mat` }, "everything (.mat)")),
    );
  }

  destroy(): void {
    this.run?.destroy();
    this.where.destroy();
    this.analysis?.destroy();
    this.fileAnalysis.destroy();
  }
}

/** "θ 0.0115°, α 0.0115°": one value per output in display units (0: "exact"). */
function sensorText(p: PlantDetail, values: number[]): string {
  return p.outputs
    .map((o, i) => {
      const d = display(o.unit);
      const v = values[i] ?? 0;
      return `${o.name} ${v > 0 ? `${fmt(v * d.scale, 3)}${d.unit === "°" ? "°" : ` ${d.unit}`}` : "exact"}`;
    })
    .join(", ");
}

/** How a run's outputs were measured, from its recorded request. */
function sensorsUsed(p: PlantDetail, run: RunInfo): string {
  if (run.mode === "rig") return "the rig's own sensors (encoder and strain gauge), as measured";
  const r = run.request as { noise?: boolean; seed?: number | null; quantize?: boolean };
  const noise = r.noise ?? (r.seed !== null && r.seed !== undefined);
  const parts = [noise ? `noise σ ${sensorText(p, p.sensors.noise_std ?? [])} (seed ${String(r.seed)})` : "no noise", r.quantize ? `quantised to ${sensorText(p, p.sensors.quantum ?? [])}` : "not quantised"];
  return `${parts.join("; ")}${noise || r.quantize ? "" : " (ideal sensors)"}`;
}
