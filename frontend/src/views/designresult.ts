// The design shown on the design page, whichever model it was made on: its gain, the verdict
// said plainly, the predicted peak input against the actuator limit, the closed loop's step,
// root locus and margins (all computed by the server), the gain to edit by hand, the
// controller to download, and the run of exactly this design. A new design clears the run
// of the last one: the run panel always belongs to the design above it.
import { API, api, ApiError } from "../api";
import { fill, h } from "../dom";
import { durationField, SignalForm, StartOptions } from "../experiment";
import { FieldSet, NumberField } from "../forms";
import { complexText, gainText, locusSeries, marginRows, peakText, verdictText } from "../designinfo";
import { chart, purge, type Series } from "../plot";
import type { Controller, ErrorDetail, LoopOut, PlantDetail, StepOut } from "../protocol.gen";
import { RunPanel } from "../runpanel";
import { display, fmt, quantity } from "../units";
import { downloadButton, errorText, showApiError } from "./common";
import { RigModeChoice } from "./rigmode";

/** A design as the page shows it. */
export interface Shown {
  /** "LQR on the physics model", "LQR on arx 4 4 1 (discrete)", … */
  title: string;
  /** the state feedback gain (null: a PID) */
  K: number[] | null;
  /** more to say: reference gain, observer poles, PID gains */
  details: string[];
  loop: LoopOut;
  /** the closed loop's response to a step of r by loop.amplitude */
  step: StepOut;
  /** a step to compare with: the predefined controller's on the physics model, or this
   * design's own on the physics model for a design on an identified model */
  compare: StepOut | null;
  /** what `compare` is ("predefined" when absent) */
  compareLabel?: string;
  /** where the model's prediction and the physics disagree, said plainly */
  warning?: string | null;
  /** outputs of the step with their SI units; the first is the reference output */
  outputs: { name: string; unit: string }[];
  /** what POST /runs takes, null: it cannot run (whyNot) */
  controller: Controller | null;
  runTs: number | null;
  whyNot: string | null;
  /** "z" designs: the sample time the gains are for */
  domain: "s" | "z";
}

export class DesignResult {
  readonly root: HTMLElement;
  private readonly result = h("section.panel.wide", { hidden: true, "data-testid": "design-result", "aria-live": "polite" });
  private readonly runBox = h("section.panel.wide", { hidden: true, "data-testid": "design-run" });
  private readonly stepDiv = h("div.chart", { "data-testid": "design-step" });
  private readonly locusDiv = h("div.chart", { "data-testid": "root-locus" });
  private readonly startOptions = new StartOptions("design-start");
  private readonly where: RigModeChoice;
  private run: RunPanel | null = null;
  private shown: Shown | null = null;

  constructor(
    readonly plant: PlantDetail,
    /** recompute with a gain typed by hand (null: no hand-editing) */
    private readonly onGain: (shown: Shown, K: number[]) => Promise<void>,
  ) {
    this.where = new RigModeChoice(plant, "design-run");
    this.root = h("div.design-result", this.result, this.runBox);
  }

  /** Say that a new design is being computed: the old one and its run go. */
  busy(title: string): void {
    void this.clearRun();
    this.shown = null;
    this.result.hidden = false;
    fill(this.result, h("h2", title), h("p.loading", { "aria-busy": "true" }, "Computing the closed loop…"));
  }

  failed(title: string, err: unknown): void {
    fill(this.result, h("h2", title), h("p.error", { role: "alert", "data-testid": "design-error" }, errorText(err)));
  }

  show(d: Shown): void {
    void this.clearRun();
    this.shown = d;
    const verdict = verdictText(d.loop);
    const ref = d.outputs[0];
    const peak = peakText(d.loop, quantity(d.loop.amplitude, ref?.unit ?? ""));
    const poles = d.loop.closed_loop_poles.map(complexText).join(", ");
    this.result.hidden = false;
    fill(
      this.result,
      h("h2", `Result: ${d.title}`),
      d.K ? h("p.mono", { "data-testid": "gain" }, gainText(d.K)) : null,
      ...d.details.map((t) => h("p.mono", t)),
      h("p.verdict", { "data-testid": "verdict", "data-stable": String(verdict.stable), class: verdict.stable ? "" : "warn" }, verdict.text),
      h("p", `Closed-loop poles (${d.domain === "z" ? "z" : "s"}): `, h("span.mono", poles)),
      h("p", { "data-testid": "peak", class: peak.warn ? "warn" : "" }, peak.text),
      this.stepInfo(d),
      d.warning ? h("p.warn", { "data-testid": "model-vs-plant", role: "status" }, d.warning) : null,
      this.stepDiv,
      this.stepDownload(d),
      h("h3", "Root locus"),
      h("p.hint", `Where the closed-loop poles go as the loop gain is scaled by k (the loop broken at the plant input; k = 1 is this design). ${d.domain === "z" ? "Stable inside the unit circle." : "Stable left of the imaginary axis."}`),
      this.locusDiv,
      h("h3", "Stability margins"),
      h("table.params", { "data-testid": "margins" }, h("tbody", ...marginRows(d.loop.margins).map(([k, v]) => h("tr", h("th", { scope: "row" }, k), h("td", v))))),
      h("p.hint", "Of the loop broken at the plant input, as the controller runs (with its state estimate)."),
      d.K ? this.handForm(d) : null,
      this.exports(d),
      this.runForm(d),
    );
    this.drawStep(d);
    this.drawLocus(d);
  }

  private stepInfo(d: Shown): HTMLElement {
    const text = (s: StepOut, verdict: string) => {
      if (verdict === "unstable") return "unstable";
      if (verdict !== "asymptotically stable") return "does not settle (not asymptotically stable)";
      const i = s.info;
      return i && i.rise_time !== null ? `rise ${fmt(i.rise_time)} s · settling ${fmt(i.settling_time)} s · overshoot ${fmt(i.overshoot)} %` : "does not settle within the horizon";
    };
    const rows = [h("tr", h("th", { scope: "row" }, "this design"), h("td", { "data-testid": "step-info" }, text(d.step, d.loop.verdict)))];
    if (d.compare) rows.push(h("tr", h("th", { scope: "row" }, d.compareLabel ?? "predefined"), h("td", { "data-testid": "step-info-compare" }, text(d.compare, d.compare.verdict))));
    return h("table.params", h("tbody", ...rows));
  }

  private drawStep(d: Shown): void {
    const series: Series[] = [];
    const unitOf = (name: string) => d.outputs.find((o) => o.name === name)?.unit ?? "";
    const ref = d.outputs[0]?.name ?? "";
    for (const o of d.outputs) {
      const dd = display(o.unit);
      series.push({ x: d.step.t, y: (d.step.outputs[o.name] ?? []).map((v) => v * dd.scale), name: `${o.name} (${dd.unit}), this design` });
    }
    if (d.compare) {
      const dd = display(unitOf(ref));
      series.push({ x: d.compare.t, y: (d.compare.outputs[ref] ?? []).map((v) => v * dd.scale), name: `${ref} (${dd.unit}), ${d.compareLabel ?? "predefined"}`, dash: "dash" });
    }
    series.push({ x: d.step.t, y: d.step.u, name: "u (V), this design", axis: 2 });
    if (d.compare) series.push({ x: d.compare.t, y: d.compare.u, name: `u (V), ${d.compareLabel ?? "predefined"}`, axis: 2, dash: "dash" });
    const refUnit = display(unitOf(ref)).unit;
    chart(this.stepDiv, series, { xTitle: "time t (s)", yTitles: [`response to a step of r by ${quantity(d.loop.amplitude, unitOf(ref))} (${refUnit})`, "u (V)"] });
  }

  private stepDownload(d: Shown): HTMLElement {
    const names = d.outputs.map((o) => o.name);
    return downloadButton("design-step.csv", ["t (s)", ...d.outputs.map((o) => `${o.name} (${o.unit})`), "u (V)"], [d.step.t, ...names.map((n) => d.step.outputs[n] ?? []), d.step.u]);
  }

  private drawLocus(d: Shown): void {
    const rl = d.loop.root_locus;
    const axis = rl.domain === "z" ? ["Re z", "Im z"] : ["Re s (1/s)", "Im s (rad/s)"];
    chart(this.locusDiv, locusSeries(rl, d.loop.closed_loop_poles), { xTitle: axis[0], yTitles: [axis[1]], square: true, height: 420 });
  }

  /** The gain as numbers to change: Recompute shows the loop of the typed K. */
  private handForm(d: Shown): HTMLElement {
    const fields = new FieldSet();
    const K = d.K ?? [];
    const grid = h("div.grid", ...K.map((k, i) => fields.add(new NumberField({ field: `K.${i}`, idPrefix: "hand", label: `K${i + 1}`, value: Number(k.toPrecision(8)), min: -1e12, max: 1e12 })).root));
    const msg = h("p.error", { role: "alert" });
    return h(
      "form.hand-gain",
      {
        novalidate: true,
        "aria-label": "gain by hand",
        onsubmit: (ev: Event) => {
          ev.preventDefault();
          const v = fields.values();
          if (!v) return void fill(msg, "Please correct the marked fields; nothing was sent.");
          void this.onGain(d, K.map((_, i) => v.get(`K.${i}`)!)).catch((err: unknown) => showApiError(err, [fields], msg));
        },
      },
      h("h3", "Change K by hand"),
      h("p.hint", "Type any gain: the page recomputes the closed loop, its step, root locus and margins for it."),
      grid,
      h("div.actions", h("button", { type: "submit" }, "Recompute with this K")),
      msg,
    );
  }

  private exports(d: Shown): HTMLElement {
    if (!d.controller) return h("p.hint", "No controller file: this design cannot run on the plant (see below).");
    const controller = d.controller;
    const msg = h("p.error", { role: "alert" });
    const button = (fmtName: "toml" | "json" | "mat", label: string) =>
      h("button.link", { type: "button", "data-testid": `export-${fmtName}`, onclick: () => void this.download(controller, fmtName, d.title).catch((err: unknown) => fill(msg, errorText(err))) }, label);
    return h("div.exports", h("h3", "Export the controller"), h("p", "As a controller file, to check offline (elab check), edit or upload: ", button("toml", "TOML"), " · ", button("json", "JSON"), " · ", button("mat", "MATLAB .mat")), msg);
  }

  private async download(controller: Controller, format: "toml" | "json" | "mat", title: string): Promise<void> {
    const name = title.slice(0, 80);
    const r = await fetch(`${API}/plants/${encodeURIComponent(this.plant.id)}/controller-file`, { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify({ controller, format, name }) });
    if (!r.ok) {
      const body = (await r.json().catch(() => null)) as { error?: ErrorDetail } | null;
      throw new ApiError(r.status, body?.error ?? { code: "invalid", message: `${r.status} ${r.statusText}`, field: null, errors: [] });
    }
    const url = URL.createObjectURL(await r.blob());
    const a = h("a", { href: url, download: `${this.plant.id}-designed.${format}` });
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 1000);
  }

  private runForm(d: Shown): HTMLElement {
    if (!d.controller) return h("p.notice", { "data-testid": "not-runnable" }, `Not runnable on the ${this.plant.name.toLowerCase()}: ${d.whyNot ?? "no controller"}.`);
    const p = this.plant;
    const unit = p.outputs.find((o) => o.name === p.reference_output)?.unit ?? "";
    const Ts = d.runTs ?? p.Ts;
    const reference = new SignalForm("signal", "Reference", ["square", "step", "sine"], unit, p.default_signal, undefined, undefined, Ts);
    const runFields = new FieldSet();
    runFields.add(durationField(p.default_duration, undefined, undefined, Ts));
    const msg = h("p.error", { role: "alert" });
    const controller = d.controller;
    // the rig steps at the plant's sample time: a discrete design for another one stays in simulation
    const onRig = !d.runTs || Math.abs(d.runTs - p.Ts) < 1e-12;
    if (!onRig) this.where.useSimulation();
    return h(
      "form.run-form",
      { novalidate: true, "aria-label": "run this design", onsubmit: (ev: Event) => (ev.preventDefault(), void this.runIt(d, controller, reference, runFields, msg)) },
      h("h3", onRig && this.where.available ? "Run it" : "Run it on the simulated plant"),
      onRig ? this.where.root : null,
      d.runTs && Math.abs(d.runTs - p.Ts) > 1e-12 ? h("p.hint", `At the model's sample time Ts = ${fmt(d.runTs * 1000)} ms (the controller is discrete).`) : null,
      reference.root,
      h("div.grid", ...[...runFields.fields.values()].map((f) => f.root)),
      this.startOptions.root,
      h("div.actions", h("button.primary", { type: "submit" }, d.K ? "Run with this K" : "Run this controller")),
      msg,
    );
  }

  private async runIt(d: Shown, controller: Controller, reference: SignalForm, runFields: FieldSet, msg: HTMLElement): Promise<void> {
    fill(msg);
    const signal = reference.value();
    const v = runFields.values();
    if (!signal || !v) return void fill(msg, "Please correct the marked fields; nothing was sent.");
    const mode = this.where.mode;
    if (this.where.blocker()) return void fill(msg, "Nothing was sent: see the rig's steps above.");
    const previous = this.run;
    try {
      const info = await api.createRun({ plant: this.plant.id, mode, experiment: "design", controller, signal, duration: v.get("duration")!, pace: "realtime", private: this.startOptions.private, ...(d.runTs && mode === "simulation" ? { Ts: d.runTs } : {}) });
      if (mode === "rig") this.where.started();
      if (this.shown !== d) {
        // a new design came while the run started: this run is not the shown design's
        await api.stop(info.id).catch(() => undefined);
        return;
      }
      this.run?.destroy();
      this.run = new RunPanel(info, this.plant);
      this.runBox.hidden = false;
      const what = d.K ? gainText(d.K, 5) : d.details.join("; ");
      fill(this.runBox, h("h2", "Run with the design above"), h("p.mono", { "data-testid": "run-gain" }, `${d.title}: ${what}`), this.run.root);
    } catch (err) {
      if (err instanceof ApiError) showApiError(err, [reference.fields, runFields], msg);
      else fill(msg, String(err));
      if (mode === "rig") this.where.refused(err);
      return;
    }
    await this.startOptions.retire(previous).catch((err: unknown) => fill(msg, `The previous run goes on: ${errorText(err)}`));
  }

  /** The run of the design that was shown goes with it (stopped if it is yours and live,
   * unless "Keep my previous run going"). */
  private async clearRun(): Promise<void> {
    const previous = this.run;
    this.run = null;
    previous?.destroy();
    this.runBox.hidden = true;
    fill(this.runBox);
    await this.startOptions.retire(previous).catch(() => undefined);
  }

  destroy(): void {
    this.run?.destroy();
    this.where.destroy();
    purge(this.stepDiv);
    purge(this.locusDiv);
  }
}
