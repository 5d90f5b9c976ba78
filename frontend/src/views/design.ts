// Controller design: state feedback by LQR or pole placement, compared with the
// predefined controller on the closed-loop step, then run live; or a controller file of
// the student's own (views/owncontroller.ts).
import { api, ApiError } from "../api";
import { fill, h } from "../dom";
import { durationField, SignalForm, StartOptions } from "../experiment";
import { FieldSet, NumberField } from "../forms";
import { discreteStep, handedModel, type HandedModel } from "../ident";
import { tex } from "../markdown";
import { chart, purge } from "../plot";
import type { DesignOut, LQRRequest, PlaceRequest, PlantDetail, StepOut } from "../protocol.gen";
import { RunPanel } from "../runpanel";
import { display, fmt } from "../units";
import { downloadButton, errorText, experimentPage, failure, loading, showApiError } from "./common";
import { OwnControllerView } from "./owncontroller";

export function designPage(root: HTMLElement, params: Record<string, string>): Promise<() => void> {
  return experimentPage(root, params.id, "design", (plant) => {
    const view = new DesignView(plant, handedModel(plant.id));
    return { content: view.root, cleanup: () => view.destroy() };
  });
}

class DesignView {
  readonly root: HTMLElement;
  private readonly method: HTMLSelectElement;
  private readonly lqr = new FieldSet();
  private readonly place = new FieldSet();
  private readonly lqrBox = h("div.grid");
  private readonly placeBox = h("div.grid", { hidden: true });
  private readonly msg = h("p.error", { role: "alert", "data-testid": "form-error" });
  private readonly result = h("section.panel.wide", { hidden: true });
  private readonly runBox = h("section.panel.wide", { hidden: true });
  private readonly chartDiv = h("div.chart", { "data-testid": "design-step" });
  private readonly modelDiv = h("div.chart", { "data-testid": "identified-step" });
  private design: DesignOut | null = null;
  private run: RunPanel | null = null;
  private readonly startOptions = new StartOptions();
  private readonly own: OwnControllerView;

  constructor(
    readonly plant: PlantDetail,
    readonly identified: HandedModel | null,
  ) {
    const n = plant.states.length;
    this.method = h("select", { id: "method", onchange: () => this.toggle() }, h("option", { value: "lqr" }, "LQR (Q, R)"), h("option", { value: "place" }, "pole placement"));
    const qDefault: number[] = plant.id === "flexible_link" ? [400, 1e4, 3, 2] : new Array<number>(n).fill(1);
    plant.states.forEach((s, i) => {
      this.lqrBox.append(this.lqr.add(new NumberField({ field: `Q.${i}`, label: `Q${i + 1}${i + 1} · ${s.label}`, value: qDefault[i] ?? 1, min: 0, max: 1e12 })).root);
    });
    this.lqrBox.append(this.lqr.add(new NumberField({ field: "R", label: "R (input weight)", value: 1, min: 0, minExclusive: true, max: 1e12 })).root);
    for (let i = 0; i < n; i++) {
      const re = -5 * (i + 1);
      this.placeBox.append(
        this.place.add(new NumberField({ field: `poles.${i}.re`, label: `pole ${i + 1}: real part`, unit: "1/s", value: re, min: -1e6, max: 1e6 })).root,
        this.place.add(new NumberField({ field: `poles.${i}.im`, label: `pole ${i + 1}: imaginary part`, unit: "rad/s", value: 0, min: -1e6, max: 1e6 })).root,
      );
    }
    const form = h(
      "form.panel",
      { novalidate: true, "aria-label": "design", onsubmit: (ev: Event) => (ev.preventDefault(), void this.compute()) },
      h("h2", "State feedback u = K (x_ref − x)"),
      h("div.field", h("label", { for: "method" }, "Method"), this.method),
      this.lqrBox,
      this.placeBox,
      h("div.actions", h("button.primary", { type: "submit" }, "Design")),
      this.msg,
    );
    const modelBox = identified ? this.identifiedPanel(identified) : null;
    this.own = new OwnControllerView(plant);
    this.root = h("div", modelBox, form, this.result, this.runBox, this.own.root);
  }

  /** The model handed over by the identification view, checked against the physics model. */
  private identifiedPanel(m: HandedModel): HTMLElement {
    const num = (x: number, power: number) => {
      const text = fmt(Math.abs(x), 4);
      if (power && text === "1") return "";
      const [mant, exp] = text.split("e");
      return exp === undefined ? mant : `${mant} \\cdot 10^{${Number(exp)}}`;
    };
    const poly = (c: number[]) => c.map((x, i) => ({ x, p: c.length - 1 - i })).filter((t) => Math.abs(t.x) > 1e-12).map((t, i) => `${t.x < 0 ? "-" : i ? "+" : ""}${num(t.x, t.p)}${t.p ? (t.p === 1 ? "z" : `z^{${t.p}}`) : ""}`).join(" ") || "0";
    const tfs = m.output.map((name, i) => {
      const el = h("div.math");
      el.innerHTML = tex(`G_{\\mathrm{${name.replace(/_/g, "\\_")}}}(z) = \\frac{${poly(m.tf[i][0].num)}}{${poly(m.tf[i][0].den)}}`, true);
      return el;
    });
    const sPoles = m.poles.map(([re, im]) => {
      const r = Math.hypot(re, im);
      return { re: Math.log(r) / m.Ts, im: Math.atan2(im, re) / m.Ts };
    });
    const c = (re: number, im: number) => `${fmt(re)}${Math.abs(im) > 1e-12 ? ` ${im < 0 ? "−" : "+"} ${fmt(Math.abs(im))}j` : ""}`;
    void this.drawIdentified(m);
    return h(
      "section.panel.wide",
      { "data-testid": "identified-model" },
      h("h2", `Identified model: ${m.name}`),
      h("p", `From ${m.source}: input ${m.input}, output${m.output.length > 1 ? "s" : ""} ${m.output.join(", ")}; Ts = ${fmt(m.Ts * 1000)} ms; validation fit ${m.fit.map((f) => `${fmt(f)} %`).join(", ")}.`),
      ...tfs,
      h("p", "Poles z: ", h("span.mono", m.poles.map(([re, im]) => c(re, im)).join(", ")), h("br"), "as continuous poles s = ln(z)/Ts: ", h("span.mono", sPoles.map((p) => c(p.re, p.im)).join(", "))),
      h("p.hint", "The step response below compares the identified model with the lab's physics model (open loop, 1 V step at u): where they agree, a controller designed on either carries over."),
      this.modelDiv,
      h("button.link", { type: "button", onclick: () => (sessionStorage.removeItem(`elab.model.${this.plant.id}`), this.root.firstElementChild?.remove()) }, "Dismiss this model"),
    );
  }

  private async drawIdentified(m: HandedModel): Promise<void> {
    const T = 2;
    const n = Math.min(Math.round(T / m.Ts) + 1, 20_000);
    const ident = discreteStep(m.ss, n);
    const t = ident[0].map((_, k) => k * m.Ts);
    let physics: StepOut | null = null;
    try {
      physics = await api.step(this.plant.id, { T: (n - 1) * m.Ts, n: Math.min(n, 4001) });
    } catch {
      /* the identified curve alone */
    }
    const series = m.output.map((name, i) => ({ x: t, y: ident[i], name: `${name}, identified (${m.units[i] || "–"})` }));
    if (physics) for (const name of m.output) if (physics.outputs[name]) series.push({ x: physics.t, y: physics.outputs[name], name: `${name}, physics model`, dash: "dash" as const } as (typeof series)[number]);
    chart(this.modelDiv, series, { xTitle: "time t (s)", yTitles: ["response to a 1 V step (SI)"], height: 320 });
  }

  private toggle(): void {
    const lqr = this.method.value === "lqr";
    this.lqrBox.hidden = !lqr;
    this.placeBox.hidden = lqr;
  }

  private async compute(): Promise<void> {
    fill(this.msg);
    const p = this.plant;
    try {
      if (this.method.value === "lqr") {
        const v = this.lqr.values();
        if (!v) return void fill(this.msg, "Please correct the marked fields; nothing was sent.");
        this.design = await api.lqr(p.id, { Q: p.states.map((_, i) => v.get(`Q.${i}`)!) as LQRRequest["Q"], R: v.get("R")! });
      } else {
        const v = this.place.values();
        if (!v) return void fill(this.msg, "Please correct the marked fields; nothing was sent.");
        this.design = await api.place(p.id, { poles: p.states.map((_, i) => ({ re: v.get(`poles.${i}.re`)!, im: v.get(`poles.${i}.im`)! })) as PlaceRequest["poles"] });
      }
    } catch (err) {
      showApiError(err, [this.lqr, this.place], this.msg);
      return;
    }
    await this.showResult(this.design);
  }

  private async showResult(d: DesignOut): Promise<void> {
    const p = this.plant;
    this.result.hidden = false;
    fill(this.result, h("h2", "Result"), loading());
    // the designed K with the same state estimate as the predefined controller: like with like
    const estimate = p.predefined.kind === "state_feedback" ? p.predefined.estimate : "true_state";
    let mine: StepOut;
    let predefined: StepOut;
    try {
      [mine, predefined] = await Promise.all([
        api.step(p.id, { controller: { kind: "state_feedback", K: d.K as [number, ...number[]], estimate } }),
        api.step(p.id, { controller: { kind: "predefined" } }),
      ]);
    } catch (err) {
      fill(this.result, h("h2", "Result"), failure(err));
      return;
    }
    const ref = p.reference_output;
    const unit = display(p.outputs.find((o) => o.name === ref)?.unit ?? "");
    const info = (s: StepOut) => (s.info ? `rise ${fmt(s.info.rise_time)} s · settling ${fmt(s.info.settling_time)} s · overshoot ${fmt(s.info.overshoot)} %` : s.verdict);
    const signalUnit = p.outputs.find((o) => o.name === ref)?.unit ?? "";
    const reference = new SignalForm("signal", "Reference", ["square", "step", "sine"], signalUnit, p.default_signal);
    const runFields = new FieldSet();
    runFields.add(durationField(p.default_duration));
    const runMsg = h("p.error", { role: "alert" });
    fill(
      this.result,
      h("h2", "Result"),
      h("p.mono", { "data-testid": "gain" }, `K = [${d.K.map((k) => fmt(k, 6)).join(", ")}]`),
      h("p", "Closed-loop poles: ", h("span.mono", d.closed_loop_poles.map((z) => `${fmt(z.re)}${z.im ? ` ${z.im < 0 ? "−" : "+"} ${fmt(Math.abs(z.im))}j` : ""}`).join(", "))),
      h("table.params", h("tbody", h("tr", h("th", { scope: "row" }, "designed"), h("td", info(mine))), h("tr", h("th", { scope: "row" }, "predefined"), h("td", info(predefined))))),
      this.chartDiv,
      downloadButton("design-step.csv", ["t (s)", `${ref} designed (SI)`, `${ref} predefined (SI)`, "u designed (V)", "u predefined (V)"], [mine.t, mine.outputs[ref] ?? [], predefined.outputs[ref] ?? [], mine.u, predefined.u]),
      h(
        "form.run-form",
        { novalidate: true, onsubmit: (ev: Event) => (ev.preventDefault(), void this.runIt(d, reference, runFields, runMsg)) },
        h("h3", "Run it"),
        reference.root,
        h("div.grid", ...[...runFields.fields.values()].map((f) => f.root)),
        this.startOptions.root,
        h("div.actions", h("button.primary", { type: "submit" }, "Run with this K")),
        runMsg,
      ),
    );
    chart(
      this.chartDiv,
      [
        { x: mine.t, y: (mine.outputs[ref] ?? []).map((v) => v * unit.scale), name: `${ref}, designed K` },
        { x: predefined.t, y: (predefined.outputs[ref] ?? []).map((v) => v * unit.scale), name: `${ref}, predefined`, dash: "dash" },
        { x: mine.t, y: mine.u, name: "u, designed K", axis: 2 },
        { x: predefined.t, y: predefined.u, name: "u, predefined", axis: 2, dash: "dash" },
      ],
      { xTitle: "time t (s)", yTitles: [`${ref} (${unit.unit}) per unit reference step`, "u (V)"] },
    );
  }

  private async runIt(d: DesignOut, reference: SignalForm, runFields: FieldSet, msg: HTMLElement): Promise<void> {
    fill(msg);
    const signal = reference.value();
    const v = runFields.values();
    if (!signal || !v) return void fill(msg, "Please correct the marked fields; nothing was sent.");
    const p = this.plant;
    const estimate = p.predefined.kind === "state_feedback" ? p.predefined.estimate : "true_state";
    const previous = this.run;
    try {
      const info = await api.createRun({ plant: this.plant.id, experiment: "design", controller: { kind: "state_feedback", K: d.K as [number, ...number[]], estimate }, signal, duration: v.get("duration")!, pace: "realtime", private: this.startOptions.private });
      this.run?.destroy();
      this.run = new RunPanel(info, this.plant);
      this.runBox.hidden = false;
      fill(this.runBox, h("h2", "Run with the designed gain"), this.run.root);
    } catch (err) {
      if (err instanceof ApiError) showApiError(err, [reference.fields, runFields], msg);
      else fill(msg, String(err));
      return;
    }
    await this.startOptions.retire(previous).catch((err: unknown) => fill(msg, `The previous run goes on: ${errorText(err)}`));
  }

  destroy(): void {
    this.run?.destroy();
    this.own.destroy();
    purge(this.chartDiv);
    purge(this.modelDiv);
  }
}
