// System analysis: a closed-loop run with the predefined controller's gains (tunable
// live), and the open-loop panels: eigenvalues, controllability/observability, transfer
// functions, Bode, open- and closed-loop step.
import { api, ApiError } from "../api";
import { describeChanges } from "../changes";
import { fill, h } from "../dom";
import { ControllerForm, durationField, InitialStateForm, SignalForm, StartOptions } from "../experiment";
import { FieldSet, type NumberField } from "../forms";
import { chart, purge } from "../plot";
import type { AnalysisInfo, BodeList, Controller, PlantDetail, RunCreate, RunInfo } from "../protocol.gen";
import { RunPanel, type RunPanelOptions } from "../runpanel";
import { typesetWhenNear } from "../texlater";
import { fmt, quantity } from "../units";
import { downloadButton, errorText, experimentPage, failure, loading, showApiError } from "./common";
import { RigModeChoice, type RunMode } from "./rigmode";
import { StepPlot } from "./stepplot";

export function analysisPage(root: HTMLElement, params: Record<string, string>, query: URLSearchParams): Promise<() => void> {
  // the panels' data asked for beside the plant's, not after it (the first plot sooner)
  const data = { analysis: quiet(api.analysis(params.id)), bode: quiet(api.bode(params.id)) };
  return experimentPage(root, params.id, "analysis", (plant) => {
    const view = new AnalysisView(plant);
    const again = query.get("run");
    if (again) void view.show(again); // a reload keeps the run on screen
    void view.loadPanels(data);
    return { content: view.root, cleanup: () => view.destroy() };
  });
}

/** A promise whose failure is handled where it is awaited, later: not reported as
 * unhandled meanwhile. */
function quiet<T>(p: Promise<T>): Promise<T> {
  p.catch(() => undefined);
  return p;
}

class AnalysisView {
  readonly root: HTMLElement;
  private readonly controller: ControllerForm;
  private readonly signal: SignalForm;
  private readonly duration: NumberField;
  private readonly runFields = new FieldSet();
  private readonly initial: InitialStateForm;
  private readonly startOptions = new StartOptions();
  private readonly where: RigModeChoice;
  private readonly outputs: HTMLSelectElement;
  private readonly startBtn: HTMLButtonElement;
  private readonly applyBtn: HTMLButtonElement;
  private readonly formMsg = h("p.error", { role: "alert", "data-testid": "form-error" });
  private readonly applied = h("p.note", { "aria-live": "polite", "data-testid": "applied" });
  private readonly runArea = h("div.run-area");
  private readonly panels = h("div.panels");
  private run: RunPanel | null = null;
  private readonly plots: HTMLElement[] = [];
  private readonly steps: StepPlot[] = [];

  constructor(readonly plant: PlantDetail) {
    const refUnit = plant.outputs.find((o) => o.name === plant.reference_output)?.unit ?? "";
    this.controller = new ControllerForm(plant, plant.predefined);
    this.signal = new SignalForm("signal", `Reference for ${plant.reference_output}`, ["square", "step", "sine"], refUnit, plant.default_signal, undefined, undefined, plant.Ts);
    this.duration = this.runFields.add(durationField(plant.default_duration, undefined, undefined, plant.Ts));
    this.initial = new InitialStateForm(plant);
    this.outputs = h(
      "select",
      { id: "outputs", onchange: () => this.run?.setOutputs(this.chosenOutputs()) },
      h("option", { value: "" }, "all outputs"),
      ...plant.outputs.map((o) => h("option", { value: o.name }, `${o.label} only`)),
    );
    this.where = new RigModeChoice(plant, "analysis", (mode) => this.modeChanged(mode));
    this.startBtn = h("button.primary", { type: "submit" }, "Start");
    this.applyBtn = h("button", { type: "button", disabled: true, onclick: () => void this.apply() }, "Apply changes to the running run");
    const form = h(
      "form.run-form.panel",
      { novalidate: true, "aria-label": "run settings", onsubmit: (ev: Event) => (ev.preventDefault(), void this.start()) },
      h("h2", "Closed-loop run"),
      this.where.root,
      this.controller.root,
      this.signal.root,
      this.initial.root,
      h("fieldset", h("legend", "Run"), h("div.grid", this.duration.root, h("div.field", h("label", { for: "outputs" }, "Plot"), this.outputs)), this.startOptions.root),
      h("small.hint.live-hint", "While a run goes, Apply changes its gains and reference from the next sample; its duration and start cannot change."),
      h("div.actions", this.startBtn, this.applyBtn),
      this.formMsg,
      this.applied,
    );
    if (plant.lesson.length) this.panels.append(this.lessonPanel());
    this.runArea.append(h("div.panel.empty", h("p", "Press Start: the closed loop runs in real time and its response draws here as it goes. Change a gain or the reference while it runs and apply it; the change is recorded at its sample.")));
    this.root = h("div", h("div.split", form, this.runArea), this.panels);
  }

  private chosenOutputs(): string[] {
    return this.outputs.value ? [this.outputs.value] : this.plant.outputs.map((o) => o.name);
  }

  private controllerValue(): Controller | null {
    return this.controller.value();
  }

  private async start(): Promise<void> {
    fill(this.formMsg);
    fill(this.applied);
    const controller = this.controllerValue();
    const signal = this.signal.value();
    const duration = this.duration.check();
    const mode = this.where.mode;
    const x0 = mode === "rig" ? undefined : this.initial.value(); // the rig starts where it is, re-zeroed
    if (!controller || !signal || duration === null || x0 === null) {
      fill(this.formMsg, "Please correct the marked fields; nothing was sent.");
      return;
    }
    const blocked = this.where.blocker();
    if (blocked) return void fill(this.formMsg, "Nothing was sent: see the rig's steps above.");
    const req: RunCreate = { plant: this.plant.id, mode, experiment: "analysis", controller, signal, duration, pace: "realtime", private: this.startOptions.private, ...(x0 ? { x0 } : {}) };
    this.startBtn.disabled = true;
    const previous = this.run;
    try {
      this.attach(await api.createRun(req));
      if (mode === "rig") this.where.started();
    } catch (err) {
      showApiError(err, [this.controller.fields, this.signal.fields, this.runFields, this.initial.fields], this.formMsg);
      if (mode === "rig") this.where.refused(err);
      return;
    } finally {
      this.startBtn.disabled = false;
    }
    await this.startOptions.retire(previous).catch((err: unknown) => fill(this.formMsg, `The previous run goes on: ${errorText(err)}`));
  }

  /** Follow an existing run of this plant (from the page's ?run= address). */
  async show(runId: string): Promise<void> {
    try {
      const info = await api.run(runId);
      if (info.plant !== this.plant.id) return;
      this.attach(info);
    } catch (err) {
      fill(this.formMsg, err instanceof ApiError ? err.message : String(err));
    }
  }

  /** The plant's lesson: its runs listed, presented one after another with one key. */
  private lessonPanel(): HTMLElement {
    const steps = this.plant.lesson;
    return h(
      "section.panel.wide.lesson",
      { "data-testid": "lesson" },
      h("h2", "Lesson: the chapter's runs, one key each"),
      h("ol", ...steps.map((step) => h("li", h("strong", step.title), ": ", step.text))),
      h("div.actions", h("button", { type: "button", "data-testid": "present-lesson", onclick: () => void this.lessonStep(0) }, "Present the lesson")),
      h("small.hint", "Each run starts in simulation and fills the screen: → or Page Down (a presenter's clicker) stops it and starts the next, Esc leaves."),
    );
  }

  /** Start step `i` of the lesson, presented, in place of the page's run. */
  private async lessonStep(i: number): Promise<void> {
    const steps = this.plant.lesson;
    const step = steps[i];
    fill(this.formMsg);
    const req: RunCreate = {
      plant: this.plant.id,
      mode: "simulation",
      experiment: "analysis",
      controller: step.controller,
      signal: step.signal,
      duration: step.duration,
      pace: "realtime",
      private: this.startOptions.private,
      ...(step.x0 ? { x0: step.x0 } : {}),
    };
    const previous = this.run;
    let info: RunInfo;
    try {
      info = await api.createRun(req);
    } catch (err) {
      previous?.present(false); // the reason shows under the form
      fill(this.formMsg, `The lesson's step ${i + 1} did not start: ${errorText(err)}`);
      return;
    }
    const next = i + 1 < steps.length ? () => void this.lessonStep(i + 1) : null;
    this.attach(info, { caption: `${i + 1} of ${steps.length} · ${step.title}: ${step.text}`, next });
    this.run?.present(true);
    await this.startOptions.retire(previous).catch((err: unknown) => fill(this.formMsg, `The previous run goes on: ${errorText(err)}`));
  }

  private attach(info: RunInfo, lesson?: RunPanelOptions["lesson"]): void {
    this.run?.destroy();
    this.run = new RunPanel(info, this.plant, { outputs: this.chosenOutputs(), onState: (s) => this.onState(s, info), lesson });
    fill(this.runArea, this.run.root);
    history.replaceState(null, "", `${location.pathname}?run=${info.id}`);
  }

  /** A rig run starts where the rig is (re-zeroed): no start state to choose. */
  private modeChanged(mode: RunMode): void {
    this.initial.disabled = mode === "rig";
    fill(this.formMsg);
  }

  private onState(state: string, run: RunInfo): void {
    const live = state === "running" || state === "paused";
    const mine = live && run.can_control;
    this.applyBtn.disabled = !mine;
    this.startBtn.textContent = live ? "Start a new run" : "Start";
    // what a running run cannot change: it is fixed until the run ends
    this.duration.disabled = mine;
    this.initial.disabled = mine || this.where.mode === "rig";
  }

  /** The gains and the reference in the form, from the next sample of the running run;
   * the server says which values that changed. */
  private async apply(): Promise<void> {
    if (!this.run) return;
    fill(this.formMsg);
    fill(this.applied);
    const controller = this.controllerValue();
    const signal = this.signal.value();
    if (!controller || !signal) {
      fill(this.formMsg, "Please correct the marked fields; nothing was sent.");
      return;
    }
    try {
      const r = await api.params(this.run.run.id, { controller, signal });
      const what = describeChanges(r.changed, this.plant);
      fill(this.applied, what ? `Changes applied from sample k = ${r.k} (t = ${r.t.toFixed(3)} s): ${what}.` : "Nothing changed: the gains and reference in the form are those the run uses.");
    } catch (err) {
      showApiError(err, [this.controller.fields, this.signal.fields], this.formMsg);
    }
  }

  async loadPanels(data: { analysis: Promise<AnalysisInfo>; bode: Promise<BodeList> }): Promise<void> {
    const eig = h("section.panel", h("h2", "Eigenvalues and stability"), loading());
    const ranks = h("section.panel", h("h2", "Controllability and observability"), loading());
    const tfs = h("section.panel", h("h2", "Transfer functions"), loading());
    const bode = h("section.panel.wide", h("h2", "Bode diagram (open loop)"), loading());
    const steps = h("section.panel.wide", h("h2", "Step responses"), loading());
    this.panels.append(eig, ranks, tfs, bode, steps);
    try {
      const a = await data.analysis;
      this.eigenPanel(eig, a);
      this.rankPanel(ranks, a);
      this.tfPanel(tfs, a);
    } catch (err) {
      for (const el of [eig, ranks, tfs]) fill(el, failure(err));
    }
    try {
      this.bodePanel(bode, await data.bode);
    } catch (err) {
      fill(bode, failure(err));
    }
    await this.stepPanel(steps);
  }

  private plotDiv(name: string): HTMLElement {
    const div = h("div.chart", { "data-testid": name });
    this.plots.push(div);
    return div;
  }

  private eigenPanel(el: HTMLElement, a: AnalysisInfo): void {
    const div = this.plotDiv("eigenvalues");
    fill(
      el,
      h("h2", "Eigenvalues and stability"),
      h("p.verdict", { "data-verdict": a.verdict }, h("strong", a.verdict), ": ", a.reason),
      h("ul.mono", ...a.eigenvalues.map((e) => h("li", `${fmt(e.re)}${e.im ? ` ${e.im < 0 ? "−" : "+"} ${fmt(Math.abs(e.im))}j` : ""}`))),
      div,
      downloadButton("eigenvalues.csv", ["re (1/s)", "im (rad/s)"], [a.eigenvalues.map((e) => e.re), a.eigenvalues.map((e) => e.im)]),
    );
    chart(div, [{ x: a.eigenvalues.map((e) => e.re), y: a.eigenvalues.map((e) => e.im), name: "open-loop poles", mode: "markers" }], { xTitle: "Re (1/s)", yTitles: ["Im (rad/s)"], height: 300 });
  }

  private rankPanel(el: HTMLElement, a: AnalysisInfo): void {
    const row = (name: string, r: AnalysisInfo["controllability"]) =>
      h("tr", h("th", { scope: "row" }, name), h("td", `${r.rank} of ${r.n}`), h("td", r.full ? "yes" : "no"), h("td", r.condition_number === null ? "∞" : fmt(r.condition_number)), h("td.mono", r.singular_values.map((v) => fmt(v)).join(", ")));
    fill(
      el,
      h("h2", "Controllability and observability"),
      h("table", h("thead", h("tr", h("th", ""), h("th", "rank"), h("th", "full"), h("th", "condition number"), h("th", "singular values"))), h("tbody", row("controllability [B AB …]", a.controllability), row("observability [C; CA; …]", a.observability))),
    );
  }

  private tfPanel(el: HTMLElement, a: AnalysisInfo): void {
    const items = a.transfer_functions.map((t) => {
      const m = h("div.math", { "data-testid": `tf-${t.output}` });
      typesetWhenNear(m, `${t.output}(s) / ${t.input}(s)`, (tex) => tex(`\\frac{${texName(t.output)}(s)}{${texName(t.input)}(s)} = ${t.latex}`, true));
      return m;
    });
    fill(el, h("h2", "Transfer functions"), ...items);
  }

  private bodePanel(el: HTMLElement, b: BodeList): void {
    const div = this.plotDiv("bode");
    const series = b.bode.flatMap((o) => [
      { x: o.omega, y: o.mag_db, name: `|G| ${o.output}`, axis: 1 as const },
      { x: o.omega, y: o.phase_deg, name: `∠G ${o.output}`, axis: 2 as const, dash: "dash" as const },
    ]);
    const cols = b.bode.flatMap((o) => [o.mag_db, o.phase_deg]);
    fill(
      el,
      h("h2", `Bode diagram (open loop, from ${b.input})`),
      div,
      downloadButton("bode.csv", ["omega (rad/s)", ...b.bode.flatMap((o) => [`${o.output} magnitude (dB)`, `${o.output} phase (deg)`])], [b.bode[0]?.omega ?? [], ...cols]),
    );
    chart(div, series, { xTitle: "frequency ω (rad/s)", yTitles: ["magnitude (dB)", "phase (°)"], logX: true });
  }

  private async stepPanel(el: HTMLElement): Promise<void> {
    const p = this.plant;
    const open = new StepPlot(p, "step-open");
    const closedPlot = new StepPlot(p, "step-closed");
    this.steps.push(open, closedPlot);
    const info = h("p.note");
    const update = h("button", { type: "button", onclick: () => void closed() }, "Update with the gains in the form");
    // the closed loop's step as big as a run's default reference (30° for the flexible
    // link), not 1 rad (57°, asking for about 20 V): the numbers a run will meet
    const ref = p.outputs.find((o) => o.name === p.reference_output);
    const amplitude = ("amplitude" in p.default_signal ? p.default_signal.amplitude : 0) || 1;
    const size = quantity(amplitude, ref?.unit ?? "");
    fill(el, h("h2", "Step responses"), h("div.two", h("div", h("h3", "Open loop (unit step of u)"), open.root), h("div", h("h3", `Closed loop (a ${size} step of ${ref?.label ?? p.reference_output}, a run's default)`), closedPlot.root, info, update)));
    try {
      open.show(await api.step(p.id, {}));
    } catch (err) {
      fill(open.root, failure(err));
    }
    const closed = async () => {
      const controller = this.controllerValue();
      if (!controller) {
        fill(info, "Please correct the marked gains first.");
        return;
      }
      try {
        const s = await api.step(p.id, { controller, amplitude });
        closedPlot.show(s);
        const i = s.info;
        const peak = Math.max(0, ...s.u.map(Math.abs));
        const limit = `${fmt(peak)} V against the actuator's ±${fmt(p.u_max)} V`;
        const beyond = p.saturate ? "a run saturates and will not follow this linear response" : "the model's actuator is not limited (saturation off), a real motor would not give it";
        const verdict = peak > p.u_max ? `${limit}: ${beyond}` : `${limit}: within it`;
        fill(info, `Closed-loop poles: ${s.verdict}. `, i ? `Rise time ${fmt(i.rise_time)} s, 2 % settling ${fmt(i.settling_time)} s, overshoot ${fmt(i.overshoot)} %. ` : "", h("span", { "data-testid": "step-peak-u" }, `Peak |u| ${verdict}.`));
      } catch (err) {
        fill(info, err instanceof ApiError ? err.message : String(err));
      }
    };
    await closed();
  }

  destroy(): void {
    this.run?.destroy();
    this.where.destroy();
    for (const d of this.plots) purge(d);
    for (const st of this.steps) st.destroy();
  }
}

const GREEK = new Set(["alpha", "beta", "gamma", "delta", "theta", "phi", "psi", "omega", "eta"]);

/** A channel name as TeX: theta → \\theta, beta2 → \\beta_{2}, x → x (issue 15: the
 * transfer functions were not labelled θ/u, α/u). */
export function texName(name: string): string {
  const m = /^([A-Za-z]+?)_?(\d*)$/.exec(name);
  if (!m) return `\\mathrm{${name.replace(/[^A-Za-z0-9]/g, "")}}`;
  const [, base, index] = m;
  const head = GREEK.has(base) ? `\\${base}` : base.length > 1 ? `\\mathrm{${base}}` : base;
  return index ? `${head}_{${index}}` : head;
}
