// The identification analysis panels: choose what to compute on a run's recording or an
// uploaded file, follow the progress, then read the data with its estimation/validation
// split, the impulse estimate with its band, the spectral Bode, the ARX order search, the
// subspace singular values, each model's fit and residuals — and hand a model to design.
import { api, ApiError, identify } from "../api";
import { fill, h } from "../dom";
import { FieldSet, NumberField } from "../forms";
import { columnNames, dataSummary, fileRecord, linkRows, modelBody, parseModels, tooLarge } from "../ident";
import { chart, purge, type Series } from "../plot";
import type { FileData, IdentModelOut, IdentOut, IdentRequest, IndirectSpec, ModelCreate, PlantDetail, RunData } from "../protocol.gen";
import { fmt } from "../units";
import { downloadButton, errorText, showApiError, verdictList } from "./common";
import { ValidationFile } from "./identvalidation";

/** Where the data come from: a run (channels by name) or a file chosen in the panel. */
export type Source = { kind: "run"; runId: string } | { kind: "file" };

export class IdentAnalysis {
  readonly root: HTMLElement;
  private readonly fields = new FieldSet();
  private readonly output: HTMLSelectElement | null = null;
  private readonly fileInput: HTMLInputElement | null = null;
  private readonly columns: { input: HTMLInputElement; output: HTMLInputElement } | null = null;
  private readonly detrend: HTMLSelectElement;
  private readonly method: HTMLSelectElement;
  private readonly references: HTMLInputElement | null = null;
  private readonly controller: { num: HTMLInputElement; den: HTMLInputElement };
  private readonly checks: Record<"correlation" | "spectral" | "arx" | "n4sid", HTMLInputElement>;
  private readonly validation: ValidationFile;
  private readonly models: HTMLInputElement;
  private readonly modelsMsg = h("small.error", { role: "alert", "data-testid": "models-error" });
  private readonly msg = h("p.error", { role: "alert", "data-testid": "ident-error" });
  private readonly progress = h("progress", { max: 1, value: 0, hidden: true, "aria-label": "identification progress" });
  private readonly stage = h("span.progress");
  private readonly results = h("div.ident-results", { "data-testid": "ident-results" });
  private readonly charts: HTMLElement[] = [];
  private busy = false;

  constructor(
    readonly plant: PlantDetail,
    readonly source: Source,
  ) {
    const pre = source.kind === "run" ? "id" : "idf"; // element ids: one page holds both
    const f = this.fields;
    const num = (field: string, label: string, value: number, min: number, max: number, extra: Partial<ConstructorParameters<typeof NumberField>[0]> = {}) => f.add(new NumberField({ field, label, value, min, max, integer: true, idPrefix: pre, ...extra })).root;
    const box = (id: string, label: string, checked = true) => {
      const input = h("input", { type: "checkbox", id, checked });
      return [input, h("label.check", input, " ", label)] as const;
    };
    const [correlation, corrLabel] = box(`${pre}-correlation`, "correlation analysis (impulse response, delay)");
    const [spectral, specLabel] = box(`${pre}-spectral`, "spectral analysis (Bode, Blackman–Tukey)");
    const [arx, arxLabel] = box(`${pre}-arx`, "ARX order search on the validation data (arxstruc)");
    const [n4sid, n4sidLabel] = box(`${pre}-n4sid`, "subspace singular values over orders");
    this.checks = { correlation, spectral, arx, n4sid };
    const rest = source.kind === "run" ? [h("option", { value: "operating_point" }, "take off the plant's rest (its operating point)")] : [];
    this.detrend = h("select", { id: `${pre}-detrend` }, h("option", { value: "mean" }, "remove the mean (MATLAB's default)"), h("option", { value: "linear" }, "remove a straight line"), h("option", { value: "none" }, "keep as recorded"), ...rest);
    // a lab run starts at rest at the operating point, u = 0: an integrating plant's data
    // are identified about that rest (a mean removed from u would add a ramp to θ; the
    // upright pendulum's π is taken off, which "as recorded" would keep)
    const atRest = source.kind === "run" && plant.integrating;
    if (atRest) this.detrend.value = "operating_point";
    const detrendWhy = atRest ? h("small.hint", { "data-testid": "detrend-why" }, "The plant's rest is taken off by default: this plant integrates (a pole at s = 0) and its runs start at rest, so removing the input's mean would add a ramp the plant never made.") : "";
    // a run gets its plant's proposals (models, resampling) with the reason; a file the general ones
    const proposed = source.kind === "run" ? plant.identification : { models: "arx:4,4,1; armax:2,2,2,1; n4sid", decimate: 1, why: "" };
    this.models = h("input.mono", { id: `${pre}-models`, value: proposed.models, spellcheck: false, autocomplete: "off", oninput: () => this.checkModels() });
    const split = f.add(new NumberField({ idPrefix: pre, field: "split", label: "Estimation share (the rest validates)", value: 0.5, min: 0, max: 1, minExclusive: true, maxExclusive: true, step: 0.05 }));
    this.validation = new ValidationFile(pre, split, source.kind === "run" ? "columns u and the output(s) above at this run's sample time, e.g. another run's CSV download" : "the same columns and sample time as the data file");
    // closed loop: the direct method, or the two-stage method from the loop's own references
    this.method = h("select", { id: `${pre}-method`, "data-testid": "ident-method" }, h("option", { value: "direct" }, "direct (u as recorded)"), h("option", { value: "two_stage" }, "two-stage (u predicted)"), h("option", { value: "indirect" }, "indirect (known C(q))"));
    this.controller = { num: h("input.mono", { id: `${pre}-indirect-num`, value: "0.6", spellcheck: false }), den: h("input.mono", { id: `${pre}-indirect-den`, value: "1", spellcheck: false }) };
    // a loop that settles within about a second: that long at the recorded rate (≤ 1000 taps)
    const taps = source.kind === "run" ? Math.min(1000, Math.max(1, Math.round(1 / plant.Ts))) : 40;
    if (source.kind === "file") this.references = h("input", { id: `${pre}-reference-cols`, value: "r" });
    const closedLoop = h(
      "fieldset",
      h("legend", "Closed loop"),
      h("div.grid", h("div.field.span2", h("label", { for: `${pre}-method` }, "Method"), this.method), num("two_stage", "First-stage taps (at the recorded rate)", taps, 1, 1000), this.references ? h("div.field", h("label", { for: `${pre}-reference-cols` }, "Reference column(s)"), this.references) : ""),
      h("div.grid", h("div.field", h("label", { for: `${pre}-indirect-num` }, "Indirect: C(q) numerator (q⁻¹ coefficients)"), this.controller.num), h("div.field", h("label", { for: `${pre}-indirect-den` }, "denominator"), this.controller.den)),
      h("small.hint", "Indirect: for a controller that acts on the measured output alone, u = w − C(q) y at the recorded rate (one input, one output, every sample). The models are fitted to the loop from w = u + C y and turned into the plant with C. The lab's own state-feedback controllers act on the plant's state, not of this kind."),
      h("small.hint", source.kind === "run" ? "In closed loop the controller feeds the sensors' noise back into u. Two-stage first predicts u from the run's reference r and its input excitation by a FIR of this many taps (the loop's settling time), then fits the models from that prediction; validation still reads the measured u. The data verdicts say how much of u the references explain." : "Two-stage: u is first predicted from the reference column(s) by a FIR of this many taps, and the models fit from that prediction; validation still reads the measured u."),
    );
    const sourceBox: HTMLElement[] = [];
    if (source.kind === "run") {
      const outputs = plant.outputs.map((o) => h("option", { value: o.name }, `${o.label} (${o.unit})`));
      this.output = h("select", { id: `${pre}-output` }, ...outputs, h("option", { value: "*" }, "all outputs (subspace models only)"));
      this.output.value = plant.reference_output;
      sourceBox.push(h("div.field", h("label", { for: `${pre}-output` }, "Output (input: u, the plant input)"), this.output));
    } else {
      this.fileInput = h("input", { type: "file", id: `${pre}-file`, accept: ".csv,.txt,.dat,.json" });
      this.columns = { input: h("input", { id: `${pre}-input-cols`, value: "u" }), output: h("input", { id: `${pre}-output-cols`, value: "y" }) };
      sourceBox.push(
        h("div.field", h("label", { for: `${pre}-file` }, "Data file (E-Lab CSV/JSON, or numeric columns; ≤ 16 MiB)"), this.fileInput),
        h("div.grid", h("div.field", h("label", { for: `${pre}-input-cols` }, "Input column(s)"), this.columns.input), h("div.field", h("label", { for: `${pre}-output-cols` }, "Output column(s)"), this.columns.output), f.add(new NumberField({ idPrefix: pre, field: "data.Ts", label: "Sample time (0: from the file)", unit: "s", value: 0, min: 0, max: 3600 })).root),
        h("small.hint", "Columns are named by the file's header; unnamed columns are c1, c2, …"),
      );
    }
    const form = h(
      "form.panel.wide",
      { novalidate: true, "aria-label": "identification analysis", onsubmit: (ev: Event) => (ev.preventDefault(), void this.run()) },
      h("h2", source.kind === "run" ? "Identify a model from this run" : "Identify a model from a data file"),
      ...sourceBox,
      this.validation.root,
      h("div.grid", split.root, h("div.field.span2", h("label", { for: `${pre}-detrend` }, "Detrend (each part)"), this.detrend, detrendWhy)),
      h("div.grid", num("decimate", "Keep every n-th sample (anti-aliased; 1: all)", proposed.decimate, 1, 100)),
      proposed.why ? h("small.hint", { "data-testid": "ident-proposed-why" }, `Proposed for this plant: ${proposed.models}, one sample in ${proposed.decimate}. ${proposed.why}`) : "",
      closedLoop,
      h("fieldset", h("legend", "Analyses"), corrLabel, specLabel, arxLabel, h("div.grid", num("arx_search.na.0", "na from", 1, 0, 50), num("arx_search.na.1", "na to", 10, 0, 50), num("arx_search.nb.0", "nb from", 1, 1, 50), num("arx_search.nb.1", "nb to", 10, 1, 50), num("arx_search.nk.0", "nk from", 1, 0, 50), num("arx_search.nk.1", "nk to", 10, 0, 50)), n4sidLabel, h("div.grid", num("n4sid_orders.0", "order from", 1, 1, 99), num("n4sid_orders.1", "order to", 10, 1, 99), num("horizon", "horizon s (0: default)", 0, 0, 100))),
      h("div.field", h("label", { for: `${pre}-models` }, "Models"), this.models, h("small.hint", "arx:na,nb,nk · armax:na,nb,nc,nk · oe:nb,nf,nk · n4sid:order[,horizon] (n4sid alone: order chosen from the singular values) · link (the flexible link's physics: outputs θ, α; detrend none or the plant's rest, every sample); separate with ;"), this.modelsMsg),
      h("div.actions", h("button.primary", { type: "submit" }, "Identify"), this.progress, this.stage),
      this.msg,
    );
    this.root = h("div.ident", { "data-testid": `ident-${source.kind}` }, form, this.results);
  }

  private checkModels(): ReturnType<typeof parseModels> {
    const parsed = parseModels(this.models.value);
    fill(this.modelsMsg, parsed.ok ? "" : parsed.message);
    this.models.setAttribute("aria-invalid", String(!parsed.ok));
    return parsed;
  }

  private async request(): Promise<IdentRequest | null> {
    const v = this.fields.values();
    const models = this.checkModels();
    if (!v || !models.ok) return null;
    const controller = this.method.value === "indirect" ? this.indirect() : null;
    if (this.method.value === "indirect" && !controller) return null;
    const records = await this.records(v);
    if (!records) return null;
    const span = (a: string): [number, number] => [v.get(`${a}.0`)!, v.get(`${a}.1`)!];
    return {
      ...records,
      ...(records.validation ? {} : { split: v.get("split")! }),
      detrend: this.detrend.value as "mean" | "linear" | "none" | "operating_point",
      correlation: this.checks.correlation.checked,
      spectral: this.checks.spectral.checked,
      arx_search: this.checks.arx.checked ? { na: span("arx_search.na"), nb: span("arx_search.nb"), nk: span("arx_search.nk") } : null,
      n4sid_orders: this.checks.n4sid.checked ? span("n4sid_orders") : null,
      horizon: v.get("horizon")! > 0 ? v.get("horizon")! : null,
      decimate: v.get("decimate")!,
      models: models.models,
      two_stage: this.method.value === "two_stage" ? v.get("two_stage")! : null,
      indirect: this.method.value === "indirect" ? controller : null,
    };
  }

  /** The indirect method's controller from its two fields (null with the reason shown). */
  private indirect(): IndirectSpec | null {
    const parse = (input: HTMLInputElement, what: string): IndirectSpec["num"] | null => {
      const parts = input.value.split(/[\s,]+/).filter(Boolean);
      const values = parts.map(Number);
      if (parts.length === 0 || parts.length > 50 || values.some((x) => !Number.isFinite(x))) {
        fill(this.msg, `The controller's ${what}: 1 to 50 numbers separated by commas or spaces (got "${input.value}").`);
        input.setAttribute("aria-invalid", "true");
        return null;
      }
      input.setAttribute("aria-invalid", "false");
      return values as IndirectSpec["num"];
    };
    const num = parse(this.controller.num, "numerator");
    const den = num && parse(this.controller.den, "denominator");
    return num && den ? { num, den } : null;
  }

  /** The data (the run, or the chosen file) and the validation file if one is chosen, with
   * the data's columns (a run's sample time: from the file); null with the reason shown. */
  private async records(v: Map<string, number>): Promise<{ data: RunData | FileData; validation: FileData | null } | null> {
    const file = this.fileInput?.files?.[0] ?? null;
    const vfile = this.validation.file;
    if (this.source.kind === "file" && !file) {
      fill(this.msg, "Choose a data file first.");
      return null;
    }
    const large = tooLarge([file, vfile].filter((x) => x !== null));
    if (large) {
      fill(this.msg, large);
      return null;
    }
    let data: RunData | FileData;
    if (this.source.kind === "run") {
      const out = this.output!.value;
      data = { source: "run", run: this.source.runId, input: ["u"], output: (out === "*" ? this.plant.outputs.map((o) => o.name) : [out]) as FileData["output"] };
    } else {
      const Ts = v.get("data.Ts")!;
      data = fileRecord(file!.name, await file!.text(), columnNames(this.columns!.input.value), columnNames(this.columns!.output.value), Ts > 0 ? Ts : null);
      if (this.method.value === "two_stage") data.reference = columnNames(this.references!.value);
    }
    const Ts = data.source === "file" ? (data.Ts ?? null) : null;
    return { data, validation: vfile ? fileRecord(vfile.name, await vfile.text(), data.input!, data.output!, Ts) : null };
  }

  private async run(): Promise<void> {
    if (this.busy) return;
    fill(this.msg);
    this.fields.clearErrors();
    const req = await this.request();
    if (!req) {
      if (!this.msg.textContent) fill(this.msg, "Please correct the marked fields; nothing was sent.");
      return;
    }
    this.busy = true;
    this.progress.hidden = false;
    this.progress.value = 0;
    try {
      const out = await identify(req, (stage, done) => {
        this.progress.value = done;
        fill(this.stage, `${stage} · ${Math.round(done * 100)} %`);
      });
      this.show(out, req);
      fill(this.stage, "done");
    } catch (err) {
      fill(this.stage);
      if (err instanceof ApiError && err.detail.field?.startsWith("models")) fill(this.modelsMsg, err.message);
      showApiError(err, [this.fields], this.msg);
    } finally {
      this.busy = false;
      this.progress.hidden = true;
    }
  }

  private chartBox(testid: string): HTMLElement {
    const div = h("div.chart", { "data-testid": testid });
    this.charts.push(div);
    return div;
  }

  private show(out: IdentOut, req: IdentRequest): void {
    for (const c of this.charts.splice(0)) purge(c);
    const d = out.data;
    const a = out.analyses;
    const sections: HTMLElement[] = [];
    const yName = (i: number) => `${d.output_names[i]} (${d.output_units[i] || "–"})`;
    // data with the split
    const split = d.estimation * d.Ts + d.t[0];
    const dataDiv = this.chartBox("ident-data");
    sections.push(h("section.panel.wide", h("h2", "Data"), h("p", { "data-testid": "ident-data-summary" }, dataSummary(d, req.validation?.source === "file" ? (req.validation.name ?? null) : null)), dataDiv));
    const dataSeries: Series[] = [];
    d.y.forEach((y, i) => dataSeries.push({ x: d.t, y, name: yName(i) }));
    d.u.forEach((u, i) => dataSeries.push({ x: d.t, y: u, name: `${d.input_names[i]} (${d.input_units[i] || "–"})`, axis: 2 }));
    const ys = d.y.flat();
    dataSeries.push({ x: [split, split], y: [Math.min(...ys), Math.max(...ys)], name: "estimation | validation", dash: "dot" });
    if (out.verdicts.length) sections.push(h("section.panel.wide", h("h2", "Verdicts on the data"), verdictList(out.verdicts, "data-verdicts")));
    if (out.notes.length) sections.push(h("section.panel.wide", h("h2", "Notes"), ...out.notes.map((n) => h("p", n))));
    // non-parametric
    if (a.correlation) {
      const c = a.correlation;
      const div = this.chartBox("ident-impulse");
      sections.push(h("section.panel", h("h2", "Impulse response (correlation analysis)"), h("p", c.delay === null ? "No lag outside the band: no clear response." : `First lag outside the ±3σ band: ${c.delay} — a delay of ${c.delay} samples (${fmt(c.delay * d.Ts * 1000)} ms).`), div, downloadButton("impulse.csv", ["lag", "impulse", "band"], [c.lags, c.impulse, c.band])));
      queueMicrotask(() => chart(div, [{ x: c.lags, y: c.impulse, name: "impulse estimate", mode: "markers" }, { x: c.lags, y: c.band, name: "+3σ", dash: "dash" }, { x: c.lags, y: c.band.map((b) => (b === null ? null : -b)), name: "−3σ", dash: "dash" }], { xTitle: "lag (samples)", yTitles: ["g(k)"], height: 300 }));
    }
    if (a.spectral) {
      const s = a.spectral;
      const div = this.chartBox("ident-spectral");
      const dB = s.magnitude.map((m) => (m === null ? null : 20 * Math.log10(m)));
      sections.push(h("section.panel", h("h2", "Frequency response (spectral analysis)"), h("p", `Hann lag window of ${s.window} lags.`), div, downloadButton("spectral.csv", ["omega_rad_s", "magnitude", "phase_deg"], [s.omega, s.magnitude, s.phase_deg])));
      queueMicrotask(() => chart(div, [{ x: s.omega, y: dB, name: "|G| (dB)" }, { x: s.omega, y: s.phase_deg, name: "∠G (°)", axis: 2 }], { xTitle: "frequency ω (rad/s)", yTitles: ["magnitude (dB)", "phase (°)"], logX: true }));
    }
    if (a.sine) {
      const s = a.sine;
      sections.push(h("section.panel", h("h2", "Sine analysis"), h("p", `At ${fmt(s.frequency_hz)} Hz (ω = ${fmt(s.omega)} rad/s), over ${s.periods_used} whole periods after the transient: |G| = ${fmt(s.magnitude)} (${fmt(s.magnitude === null ? null : 20 * Math.log10(s.magnitude))} dB), ∠G = ${fmt(s.phase_deg)}°.`)));
    }
    if (a.arx_search) {
      const s = a.arx_search;
      const best = new Map<number, number>();
      for (const [na, nb, , V] of s.rows) if (na !== null && nb !== null && V !== null) best.set(na + nb, Math.min(best.get(na + nb) ?? Infinity, V));
      const ds = [...best.keys()].sort((x, y) => x - y);
      const minLoss = Math.min(...s.rows.map((r) => r[3] ?? Infinity));
      const div = this.chartBox("ident-arx-search");
      sections.push(h("section.panel", h("h2", "ARX order search"), h("p", `${s.rows.length} structures; least validation loss ${fmt(minLoss)} at [na nb nk] = [${s.best.join(" ")}]; AIC picks [${s.aic.join(" ")}], MDL [${s.mdl.join(" ")}].`), div, downloadButton("arx-search.csv", ["na", "nb", "nk", "loss"], [0, 1, 2, 3].map((j) => s.rows.map((r) => r[j])))));
      queueMicrotask(() => chart(div, [{ x: ds, y: ds.map((k) => best.get(k)!), name: "least loss per parameter count", mode: "markers" }], { xTitle: "parameters na + nb", yTitles: ["validation loss"], height: 300 }));
    }
    if (a.n4sid_orders) {
      const o = a.n4sid_orders;
      const sv = o.singular_values.slice(0, 30);
      const div = this.chartBox("ident-singular-values");
      sections.push(h("section.panel", h("h2", "Subspace: singular values"), h("p", `Horizon ${o.horizon}. The order where they drop is the model's order; over ${o.orders[0].order}…${o.orders[o.orders.length - 1].order}: ${o.best} (${o.reason})`), div, downloadButton("singular-values.csv", ["index", "sigma"], [sv.map((_, i) => i + 1), sv])));
      queueMicrotask(() => chart(div, [{ x: sv.map((_, i) => i + 1), y: sv.map((x) => (x === null ? null : Math.log10(x))), name: "log₁₀ σ", mode: "markers" }], { xTitle: "index (order)", yTitles: ["log₁₀ singular value"], height: 300 }));
    }
    if (out.models.length) sections.push(this.modelsSection(out, req));
    fill(this.results, ...sections);
    queueMicrotask(() => chart(dataDiv, dataSeries, { xTitle: "time t (s)", yTitles: ["outputs", "input"] }));
  }

  private modelsSection(out: IdentOut, req: IdentRequest): HTMLElement {
    const d = out.data;
    const models = out.models;
    const source = this.source.kind === "run" ? `run ${this.source.runId}` : ((req.data as FileData).name ?? "upload");
    const rows = models.map((m, i) =>
      h(
        "tr",
        h("th", { scope: "row" }, m.name),
        h(m.fit.headline_x0 === "zero" ? "td.headline" : "td", { "data-testid": `fit-zero-${i}` }, m.fit.validation_simulation.map((x) => `${fmt(x)} %`).join(", ")),
        h(m.fit.headline_x0 === "estimated" ? "td.headline" : "td", { "data-testid": `fit-x0-${i}`, title: m.fit.headline_x0 === "estimated" ? m.fit.headline_why : "" }, m.fit.validation_simulation_x0.map((x) => `${fmt(x)} %`).join(", ")),
        h("td", m.fit.validation_one_step.map((x) => `${fmt(x)} %`).join(", ")),
        h("td", m.stable ? "stable" : "unstable"),
        h(`td.level-${m.level}`, { "data-testid": `model-level-${i}` }, m.level),
        h("td", h("button.button", { type: "button", "data-testid": `use-model-${i}`, title: "Keep this model on the server and design a controller on it (a page you can share)", onclick: (ev: Event) => void this.useModel(ev.currentTarget as HTMLButtonElement, modelBody(this.plant.id, out, i, source), m) }, "Use this model"), " ", h("button.link", { type: "button", onclick: () => this.saveModel(m) }, "JSON")),
      ),
    );
    const compareDiv = this.chartBox("ident-compare");
    const n0 = d.estimation;
    const tv = d.t.filter((_, k) => k * d.step >= n0);
    const series: Series[] = [];
    d.y.forEach((y, i) => series.push({ x: tv, y: y.slice(y.length - tv.length), name: `measured ${d.output_names[i]}` }));
    for (const m of models) {
      // the plot shows the fit the table leads with: from x₀ = 0, or from the fitted x₀
      const fitted = m.fit.headline_x0 === "estimated";
      (fitted ? m.simulated_x0 : m.simulated).forEach((y, i) => series.push({ x: tv, y: y.slice(0, tv.length), name: `${m.name}${d.output_names.length > 1 ? " " + d.output_names[i] : ""}${fitted ? " (x₀ fitted)" : ""}`, dash: "dash" }));
    }
    const why = models.filter((m) => m.fit.headline_x0 === "estimated").map((m) => h("li", `${m.name}: ${m.fit.headline_why}.`));
    const physics = models
      .filter((m) => m.kind === "link")
      .map((m) =>
        h(
          "div",
          h("h3", `${m.name}: the flexible link's physics`),
          h("table.params", { "data-testid": "link-parameters" }, h("thead", h("tr", h("th", "ratio"), h("th", "estimate ± σ"), h("th", "what it is"))), h("tbody", ...linkRows(m).map(([n, v, what]) => h("tr", h("th", { scope: "row" }, n), h("td.mono", v), h("td", what))))),
          h("p.hint", `The servo equation fitted where the servo turned faster than 1 rad/s (${Number(m.parameters.moving_samples).toLocaleString("en")} of ${Number(m.parameters.samples).toLocaleString("en")} samples); the fits above are of its linear part, without friction or dead zone.`),
        ),
      );
    const residDivs: HTMLElement[] = [];
    const residBlocks = models.flatMap((m) => {
      const r = m.residuals;
      if (!r) return [];
      const div = this.chartBox(`ident-resid-${m.kind}`);
      residDivs.push(div);
      queueMicrotask(() =>
        chart(
          div,
          [
            { x: r.lags, y: r.autocorrelation, name: "autocorrelation of ε", mode: "markers" },
            { x: r.lags, y: r.lags.map(() => r.bound), name: "99 % bound", dash: "dash" },
            { x: r.cross_lags, y: r.cross_correlation, name: "cross-correlation ε–u", mode: "markers", axis: 2 },
            { x: r.cross_lags, y: r.cross_lags.map(() => r.bound), name: "99 % bound ", dash: "dash", axis: 2 },
          ],
          { xTitle: "lag (samples)", yTitles: ["r_ε(τ)", "r_εu(τ)"], height: 380 },
        ),
      );
      return h("div", h("h3", `${m.name}: residuals ${r.white ? "white" : "not white"}, ${r.independent ? "independent of the input" : "correlated with the input"}`), div);
    });
    queueMicrotask(() => chart(compareDiv, series, { xTitle: "time t (s)", yTitles: ["validation output"] }));
    return h(
      "section.panel.wide",
      h("h2", "Models on the validation data"),
      h("table.params", { "data-testid": "ident-models" }, h("thead", h("tr", h("th", "model"), h("th", "fit, simulated (x₀ = 0)"), h("th", "fit, simulated (x₀ fitted)"), h("th", "fit, one step ahead"), h("th", "poles"), h("th", "verdict"), h("th", ""))), h("tbody", ...rows)),
      h("p.hint", `Fit = 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖) on the ${d.validation === "record" ? "separate validation record" : "validation part"}; the bold one is each model's headline, and the one plotted: from x₀ = 0 when every mode decays within the record, else from the fitted initial state. Use this model: the server keeps it and opens its design page, a link you can share, where LQR, pole placement and PID are designed on it and run on the plant.`),
      why.length ? h("ul.hint", { "data-testid": "ident-headline-why" }, ...why) : "",
      ...models.map((m, i) => {
        const said = m.verdicts.filter((v) => v.level !== "good");
        return said.length ? h("div", h("h3", `${m.name}: ${m.level}`), verdictList(said, `model-verdicts-${i}`)) : "";
      }),
      ...physics,
      compareDiv,
      ...residBlocks,
    );
  }

  /** Keep the model on the server, then open its design page (its shareable link). A
   * model the verdicts call poor is kept only on a second click, after the warning. */
  private async useModel(button: HTMLButtonElement, body: ModelCreate, m: IdentModelOut): Promise<void> {
    if (m.level === "poor" && button.dataset.warned !== "yes") {
      button.dataset.warned = "yes";
      button.textContent = "Use it anyway";
      const why = m.verdicts.filter((v) => v.level === "poor").map((v) => v.finding);
      fill(this.msg, h("span", { "data-testid": "poor-model-warning" }, `${m.name} is a poor model: ${why.join("; ")}. A controller designed on it is designed for another plant. Click “Use it anyway” to keep it regardless.`));
      return;
    }
    button.disabled = true;
    fill(this.msg);
    try {
      const kept = await api.createModel(body);
      history.pushState(null, "", kept.page);
      window.dispatchEvent(new PopStateEvent("popstate")); // the router shows the page
    } catch (err) {
      fill(this.msg, `The model was not kept: ${errorText(err)}`);
      button.disabled = false;
    }
  }

  private saveModel(m: IdentModelOut): void {
    const blob = new Blob([JSON.stringify(m, null, 1)], { type: "application/json" });
    const a = h("a", { href: URL.createObjectURL(blob), download: `${m.name.replace(/\s+/g, "-")}.json` });
    a.click();
    URL.revokeObjectURL(a.href);
  }

  destroy(): void {
    for (const c of this.charts.splice(0)) purge(c);
  }
}
