// An identified model on the design page (?model=ID): the model as the server keeps it —
// transfer functions, poles, its step beside the physics model's, a link to share, its
// files — and a design on it: LQR, pole placement or PID, in discrete or continuous time,
// computed by the server (python-control), shown by DesignResult.
import { API, api, ApiError } from "../api";
import { copyText, fill, h } from "../dom";
import { FieldSet, NumberField } from "../forms";
import { complexText } from "../designinfo";
import { tex } from "../markdown";
import { chart, purge, type Series } from "../plot";
import type { IdentifiedModel, ModelDesignOut, ModelDesignRequest, PlantDetail, StepOut } from "../protocol.gen";
import { display, fmt, quantity } from "../units";
import { errorText, loading, verdictList } from "./common";
import type { DesignResult, Shown } from "./designresult";

type Method = "lqr" | "place" | "pid";
type Domain = "discrete" | "continuous";
/** Bryson's rule's largest acceptable u, as a share of the actuator's limit (the server's
 * default output weight too) */
const BRYSON_SHARE = 0.8;
const METHOD_NAME: Record<Method | "gain", string> = { lqr: "LQR", place: "pole placement", pid: "PID", gain: "K typed by hand" };

export class ModelDesign {
  readonly root: HTMLElement;
  private readonly panel = h("section.panel.wide", { "data-testid": "identified-model" }, loading("Loading the model…"));
  private readonly formBox = h("div");
  private readonly stepDiv = h("div.chart", { "data-testid": "identified-step" });
  private readonly shownHere = new WeakSet<Shown>();
  private model: IdentifiedModel | null = null;
  private form: ModelForm | null = null;

  constructor(
    readonly plant: PlantDetail,
    readonly modelId: string,
    private readonly result: DesignResult,
  ) {
    this.root = h("div", this.panel, this.formBox);
    void api.model(modelId).then(
      (m) => this.loaded(m),
      (err: unknown) => fill(this.panel, h("h2", "Identified model"), h("p.error", { role: "alert", "data-testid": "model-error" }, `Model ${modelId}: ${errorText(err)}`)),
    );
  }

  owns(shown: Shown): boolean {
    return this.shownHere.has(shown);
  }

  private loaded(m: IdentifiedModel): void {
    this.model = m;
    if (m.plant !== this.plant.id) {
      fill(this.panel, h("h2", `Identified model: ${m.name}`), h("p.error", { role: "alert" }, `This model is of the ${m.plant.replace(/_/g, " ")}: open it on its own design page.`), h("a", { href: m.page, "data-link": "" }, m.page));
      return;
    }
    fill(this.panel, ...this.describe(m));
    void this.drawStep(m);
    this.form = new ModelForm(this.plant, m, (req) => this.design(req));
    fill(this.formBox, this.form.root);
  }

  private describe(m: IdentifiedModel): (HTMLElement | null)[] {
    const out = m.outputs.map((o) => `${o.name} (${o.unit || "–"})`).join(", ");
    const fit = m.fit.length ? `; validation fit ${m.fit.map((f) => `${fmt(f)} %`).join(", ")}` : "";
    const warned = m.verdicts.filter((v) => v.level !== "good");
    const tfs = m.tf.map((t, i) => {
      const el = h("div.math", { "data-testid": "model-tf" });
      const G = `G_{\\mathrm{${m.outputs[i].name.replace(/_/g, "\\_")}}}(z)`;
      if (Math.max(t.num.length, t.den.length) <= LONG_POLY) {
        el.innerHTML = tex(`${G} = \\frac{${poly(t.num)}}{${poly(t.den)}}`, true);
        return el;
      }
      // a long fraction would run off the page: its polynomials on lines of their own,
      // inline, where KaTeX breaks lines after each + and − (issue 27: a 10th-order model
      // was cut off)
      el.innerHTML = [tex(`${G} = \\dfrac{B(z)}{A(z)}`, true), `<p>${tex(`B(z) = ${poly(t.num)}`)}</p>`, `<p>${tex(`A(z) = ${poly(t.den)}`)}</p>`].join("");
      return el;
    });
    const url = new URL(m.page, location.origin).href;
    const copy = h("button.link", { type: "button", "data-testid": "copy-model-link", onclick: () => void copyText(url, copy, "Link copied") }, "Copy link");
    const del = m.can_delete ? h("button.link.danger", { type: "button", "data-testid": "delete-model", onclick: () => void this.remove(m) }, "Delete this model") : null;
    const file = (format: "json" | "mat", label: string) => h("a", { href: `${API}/models/${encodeURIComponent(m.id)}/file?format=${format}`, download: "", "data-testid": `model-file-${format}` }, label);
    return [
      h("h2", `Identified model: ${m.name}`),
      h("p", `From ${m.source || "an upload"}${m.kind ? ` (${m.kind})` : ""}: input ${m.input.name} (${m.input.unit || "–"}), output${m.outputs.length > 1 ? "s" : ""} ${out}; Ts = ${fmt(m.Ts * 1000)} ms${fit}. Kept by ${m.mine ? "you" : m.owner}.`),
      warned.length ? h("div.warnings", h("h4", "Identification's verdicts on this model"), verdictList(warned, "model-warnings")) : null,
      ...tfs,
      h("p", "Poles z: ", h("span.mono", m.poles.map(complexText).join(", ")), h("br"), "as continuous poles s = ln(z)/Ts: ", h("span.mono", m.poles_s ? m.poles_s.map(complexText).join(", ") : "none (a pole at z ≤ 0 has no continuous equivalent)")),
      h("p.share", "Link to this page, for anyone: ", h("a.mono", { href: m.page, "data-link": "", "data-testid": "model-link" }, url), " ", copy),
      h("p", "The model as a file: ", file("json", "JSON"), " · ", file("mat", "MATLAB .mat"), del ? " · " : "", del),
      m.not_runnable ? h("p.notice", { "data-testid": "model-not-runnable" }, `Designs on this model can be analysed but not run on the plant: ${m.not_runnable}.`) : null,
      h("p.hint", "Open-loop response to a 1 V step at u: the identified model (computed on the server) beside the lab's physics model. Where they agree, a controller designed on either carries over."),
      this.stepDiv,
    ];
  }

  private async drawStep(m: IdentifiedModel): Promise<void> {
    const T = 2;
    let ident: StepOut;
    try {
      ident = await api.modelStep(m.id, T);
    } catch (err) {
      fill(this.stepDiv, h("p.error", errorText(err)));
      return;
    }
    const physics = await api.step(this.plant.id, { T, n: 2001 }).catch(() => null);
    const series: Series[] = m.outputs.map((o) => ({ x: ident.t, y: ident.outputs[o.name] ?? [], name: `${o.name}, identified (${o.unit || "–"})` }));
    if (physics) for (const o of m.outputs) if (physics.outputs[o.name]) series.push({ x: physics.t, y: physics.outputs[o.name], name: `${o.name}, physics model (${o.unit})`, dash: "dash" });
    chart(this.stepDiv, series, { xTitle: "time t (s)", yTitles: ["response to a 1 V step (SI units)"], height: 320 });
  }

  private async remove(m: IdentifiedModel): Promise<void> {
    if (!window.confirm(`Delete the model ${m.name}? Its link stops working.`)) return;
    try {
      await api.deleteModel(m.id);
    } catch (err) {
      window.alert(errorText(err));
      return;
    }
    history.pushState(null, "", `/plants/${this.plant.id}/design`);
    window.dispatchEvent(new PopStateEvent("popstate"));
  }

  /** A design on the model, shown below; the form's own errors stay in the form. */
  private async design(req: ModelDesignRequest): Promise<void> {
    const m = this.model;
    if (!m) return;
    const title = `${METHOD_NAME[req.method]} on ${m.name} (${req.domain ?? "discrete"})`;
    this.result.busy(title);
    let d: ModelDesignOut;
    try {
      d = await api.designOnModel(m.id, req);
    } catch (err) {
      this.result.failed(title, err);
      throw err;
    }
    this.result.show(this.shown(m, d, title));
  }

  async byHand(K: number[]): Promise<void> {
    await this.design({ method: "gain", K: K as [number, ...number[]], domain: this.form?.domain ?? "discrete" });
  }

  private shown(m: IdentifiedModel, d: ModelDesignOut, title: string): Shown {
    const ref = m.outputs.find((o) => o.name === this.plant.reference_output) ?? m.outputs[0];
    const z = d.domain === "discrete";
    const details: string[] = [];
    if (d.weight_note) details.push(d.weight_note);
    else if (d.output_weight !== null && d.output_weight !== undefined) details.push(`q = ${fmt(d.output_weight, 4)}`);
    if (d.Nr !== null) details.push(`Nr = ${fmt(d.Nr, 6)} (u = Nr r − K x̂: r passes at unit gain)`);
    if (d.observer_poles) details.push(`observer poles (${z ? "z" : "s"}): ${d.observer_poles.map(complexText).join(", ")}`);
    if (d.controller?.kind === "pid") details.push(`Kp = ${fmt(d.controller.Kp)}, Ki = ${fmt(d.controller.Ki ?? 0)}, Kd = ${fmt(d.controller.Kd ?? 0)}, N = ${fmt(d.controller.N ?? 10)}`);
    if (z) details.push(`discrete at Ts = ${fmt(m.Ts * 1000)} ms, on the model's own states`);
    const shown: Shown = {
      title,
      K: d.K,
      details,
      loop: d,
      step: d.step,
      compare: d.on_plant,
      compareLabel: "on the physics model",
      warning: d.on_plant ? disagreement(d.step, d.on_plant, d.verdict) : null,
      outputs: [ref, ...m.outputs.filter((o) => o !== ref)],
      controller: d.controller,
      runTs: d.run_Ts,
      whyNot: d.not_runnable,
      domain: z ? "z" : "s",
    };
    this.shownHere.add(shown);
    return shown;
  }

  destroy(): void {
    purge(this.stepDiv);
  }
}

/** The design form: method, domain, and the method's numbers. */
class ModelForm {
  readonly root: HTMLElement;
  private readonly method: HTMLSelectElement;
  private readonly domainSel: HTMLSelectElement;
  private readonly fields = new FieldSet();
  private readonly body = h("div");
  private readonly msg = h("p.error", { role: "alert", "data-testid": "model-form-error" });
  private readonly robust = h("input", { type: "checkbox", id: "model-robust", checked: true });
  /** Bryson's q as the form shows it: sent as no weight (the server's Bryson) unless changed. */
  private bryson = Number.NaN;

  constructor(
    readonly plant: PlantDetail,
    readonly model: IdentifiedModel,
    private readonly submit: (req: ModelDesignRequest) => Promise<void>,
  ) {
    this.method = h("select", { id: "model-method", onchange: () => this.build() }, h("option", { value: "lqr" }, "LQR"), h("option", { value: "place" }, "pole placement"), h("option", { value: "pid" }, "PID"));
    this.domainSel = h("select", { id: "model-domain", onchange: () => this.build() }, h("option", { value: "discrete" }, "discrete (z)"), h("option", { value: "continuous", disabled: model.poles_s === null }, "continuous (s)"));
    this.root = h(
      "form.panel.wide",
      { novalidate: true, "aria-label": "design on the identified model", onsubmit: (ev: Event) => (ev.preventDefault(), void this.send()) },
      h("h2", `Design on ${model.name}`),
      h("div.grid", h("div.field", h("label", { for: "model-method" }, "Method"), this.method), h("div.field", h("label", { for: "model-domain" }, "Time"), this.domainSel)),
      this.body,
      h("p.hint", "State feedback acts on a full-order observer's estimate x̂ of the model's states (their poles three times faster than the loop's by default), u = Nr r − K x̂; the step, root locus and margins are those of the loop as it runs."),
      h("div.actions", h("button.primary", { type: "submit" }, "Design")),
      this.msg,
    );
    this.build();
  }

  get domain(): Domain {
    return this.domainSel.value as Domain;
  }

  private amplitude(): { si: number; unit: string } {
    const s = this.plant.default_signal;
    const si = "amplitude" in s && s.amplitude ? Math.abs(s.amplitude) : 1;
    return { si, unit: this.plant.outputs.find((o) => o.name === this.plant.reference_output)?.unit ?? "" };
  }

  private build(): void {
    this.fields.fields.clear();
    const add = (f: NumberField) => this.fields.add(f).root;
    const z = this.domain === "discrete";
    const n = this.model.A.length;
    const method = this.method.value as Method;
    if (method === "lqr") {
      const a = this.amplitude();
      const q = ((BRYSON_SHARE * this.plant.u_max) / a.si) ** 2;
      this.bryson = Number(q.toPrecision(4));
      const unit = display(a.unit);
      fill(
        this.body,
        h("div.grid", add(new NumberField({ field: "output_weight", idPrefix: "model", label: "q: weight on the output (Q = q Cᵀ C)", unit: `1/${a.unit || "unit"}²`, value: Number(q.toPrecision(4)), min: 0, minExclusive: true, max: 1e12 })), add(new NumberField({ field: "R", idPrefix: "model", label: "R: weight on u", unit: "1/V²", value: 1, min: 0, minExclusive: true, max: 1e12 }))),
        h("label.check", this.robust, " Lower q until the loop has 6 dB of gain and 30° of phase margin (recommended: an identified model's resonance is never exact)"),
        h("small.hint", `Default by Bryson's rule: q = (u / step)² with u = 80 % of the actuator's limit: (${fmt(BRYSON_SHARE * this.plant.u_max)} V / ${quantity(a.si, a.unit)})², so a step of ${fmt(a.si * unit.scale)}${unit.unit === "°" ? "°" : ` ${unit.unit}`} asks for about that much. ${z ? "Discrete LQR (dlqr) on the model at its Ts" : "LQR on the continuous model"}; the time is "discrete" for the model as identified, "continuous" for its zero-order-hold inverse.`),
      );
    } else if (method === "place") {
      const grid = h("div.grid");
      for (let i = 0; i < n; i++) {
        const s = -5 * (i + 1);
        const re = z ? Number(Math.exp(s * this.model.Ts).toPrecision(6)) : s;
        grid.append(add(new NumberField({ field: `poles.${i}.re`, idPrefix: "model", label: `pole ${i + 1}: real part`, unit: z ? "" : "1/s", value: re, min: -1e6, max: 1e6 })), add(new NumberField({ field: `poles.${i}.im`, idPrefix: "model", label: `pole ${i + 1}: imaginary part`, unit: z ? "" : "rad/s", value: 0, min: -1e6, max: 1e6 })));
      }
      fill(this.body, grid, h("small.hint", z ? `Closed-loop poles in z (stable inside |z| < 1; z = e^(s·Ts): s = −5/s is z = ${fmt(Math.exp(-5 * this.model.Ts), 6)}).` : "Closed-loop poles in s (stable left of the imaginary axis)."));
    } else {
      const pre = this.plant.predefined.kind === "pid" ? this.plant.predefined : null;
      fill(
        this.body,
        h(
          "div.grid",
          add(new NumberField({ field: "Kp", idPrefix: "model", label: "Kp", value: pre?.Kp ?? 1, min: -1e6, max: 1e6 })),
          add(new NumberField({ field: "Ki", idPrefix: "model", label: "Ki", value: pre?.Ki ?? 0, min: -1e6, max: 1e6 })),
          add(new NumberField({ field: "Kd", idPrefix: "model", label: "Kd", value: pre?.Kd ?? 0, min: -1e6, max: 1e6 })),
          add(new NumberField({ field: "N", idPrefix: "model", label: "N (derivative filter)", value: pre?.N ?? 10, min: 0, minExclusive: true, max: 1e6 })),
        ),
        h("small.hint", `u = Kp e + Ki ∫e + Kd s/(Tf s + 1) e on e = r − ${this.plant.reference_output}; ${z ? "Tustin at the model's Ts, as a run steps it." : "continuous."}`),
      );
    }
  }

  private request(v: Map<string, number>): ModelDesignRequest {
    const domain = this.domain;
    const method = this.method.value as Method;
    if (method === "lqr") {
      const q = v.get("output_weight")!;
      return { method, domain, output_weight: q === this.bryson ? null : q, R: v.get("R")!, robust: this.robust.checked };
    }
    if (method === "place") {
      const poles = this.model.A.map((_, i) => ({ re: v.get(`poles.${i}.re`)!, im: v.get(`poles.${i}.im`)! }));
      return { method, domain, poles: poles as [{ re: number; im: number }, ...{ re: number; im: number }[]] };
    }
    return { method, domain, Kp: v.get("Kp")!, Ki: v.get("Ki")!, Kd: v.get("Kd")!, N: v.get("N")! };
  }

  private async send(): Promise<void> {
    fill(this.msg);
    const v = this.fields.values();
    if (!v) return void fill(this.msg, "Please correct the marked fields; nothing was sent.");
    try {
      await this.submit(this.request(v));
    } catch (err) {
      this.showError(err);
    }
  }

  /** Server errors next to their fields ("lqr.R" → the R field); the rest under the form. */
  private showError(err: unknown): void {
    this.fields.clearErrors();
    if (!(err instanceof ApiError)) return void fill(this.msg, String(err));
    const named = new Map([...err.fieldMessages()].map(([f, m]) => [f.replace(/^(lqr|place|gain|pid)\./, ""), m]));
    const rest = this.fields.showErrors(named);
    fill(this.msg, rest.size ? [...rest].map(([f, m]) => (m.startsWith(f) ? m : `${f}: ${m}`)).join("; ") : "Please correct the marked fields.");
  }
}

/** A polynomial in z as LaTeX, highest power first. */
/** What a design on an identified model does on the physics model that the model did not
 * predict (null: they agree): another verdict, a response that does not settle, or
 * overshoot 10 points or settling 1.5× apart (issue 26: 0 % predicted, 30 % on the plant). */
export function disagreement(model: StepOut, plant: StepOut, verdict: string): string | null {
  const after = "The identified model misses dynamics that matter to this loop: check its validation and residuals, or identify it again, before running it on the rig.";
  if (plant.verdict !== verdict) return `On the physics model this design is ${plant.verdict}; the identified model says ${verdict}. ${after}`;
  const m = model.info;
  const p = plant.info;
  if (!m || !p || m.overshoot === null || m.settling_time === null) return null;
  if (p.overshoot === null || p.settling_time === null) return `On the physics model this design does not settle within ${fmt(plant.t[plant.t.length - 1])} s; the identified model predicts settling in ${fmt(m.settling_time)} s. ${after}`;
  const far = Math.abs(p.overshoot - m.overshoot) >= 10 || p.settling_time > 1.5 * m.settling_time || m.settling_time > 1.5 * p.settling_time;
  return far ? `On the physics model this design overshoots ${fmt(p.overshoot)} % and settles in ${fmt(p.settling_time)} s; the identified model predicts ${fmt(m.overshoot)} % and ${fmt(m.settling_time)} s. ${after}` : null;
}

/** Coefficients beyond which a transfer function's polynomials get lines of their own. */
const LONG_POLY = 5;

function poly(c: number[]): string {
  const num = (x: number, power: number) => {
    const text = fmt(Math.abs(x), 4);
    if (power && text === "1") return "";
    const [mant, exp] = text.split("e");
    return exp === undefined ? mant : `${mant} \\cdot 10^{${Number(exp)}}`;
  };
  const terms = c.map((x, i) => ({ x, p: c.length - 1 - i })).filter((t) => Math.abs(t.x) > 1e-12);
  return terms.map((t, i) => `${t.x < 0 ? "-" : i ? "+" : ""}${num(t.x, t.p)}${t.p ? (t.p === 1 ? "z" : `z^{${t.p}}`) : ""}`).join(" ") || "0";
}
