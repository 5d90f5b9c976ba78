// Controller design: on an identified model (?model=ID, a link anyone may open) or on the
// lab's physics model — LQR, pole placement, a gain typed by hand, PID on a model — with
// the closed loop's step, root locus, margins and peak input from the server, then run on
// the simulated plant; or a controller file of the student's own (views/owncontroller.ts).
import { api } from "../api";
import { fill, h } from "../dom";
import { FieldSet, NumberField } from "../forms";
import type { LQRRequest, PlaceRequest, PlantDetail, StateFeedbackController } from "../protocol.gen";
import { experimentPage, showApiError } from "./common";
import { DesignResult, type Shown } from "./designresult";
import { ModelDesign } from "./designmodel";
import { OwnControllerView } from "./owncontroller";

export function designPage(root: HTMLElement, params: Record<string, string>, query: URLSearchParams): Promise<() => void> {
  return experimentPage(root, params.id, "design", (plant) => {
    const view = new DesignView(plant, query.get("model"));
    return { content: view.root, cleanup: () => view.destroy() };
  });
}

class DesignView {
  readonly root: HTMLElement;
  private readonly result: DesignResult;
  private readonly model: ModelDesign | null;
  private readonly own: OwnControllerView;

  constructor(
    readonly plant: PlantDetail,
    modelId: string | null,
  ) {
    this.result = new DesignResult(plant, (shown, K) => this.byHand(shown, K));
    this.model = modelId ? new ModelDesign(plant, modelId, this.result) : null;
    const physics = new PhysicsDesign(plant, this.result);
    this.own = new OwnControllerView(plant);
    const onPhysics = this.model ? h("details.panel.wide", h("summary", "Or design on the lab's physics model"), physics.root) : physics.root;
    this.root = h("div", this.model?.root, onPhysics, this.result.root, this.own.root);
  }

  /** A gain typed by hand, on the model the shown design was made on. */
  private async byHand(shown: Shown, K: number[]): Promise<void> {
    if (this.model?.owns(shown)) return this.model.byHand(K);
    return PhysicsDesign.byHand(this.plant, this.result, K);
  }

  destroy(): void {
    this.result.destroy();
    this.model?.destroy();
    this.own.destroy();
  }
}

/** State feedback u = K (x_ref − x) on the physics model, by LQR or pole placement. */
class PhysicsDesign {
  readonly root: HTMLElement;
  private readonly method: HTMLSelectElement;
  private readonly lqr = new FieldSet();
  private readonly place = new FieldSet();
  private readonly lqrBox = h("div.grid");
  private readonly placeBox = h("div.grid", { hidden: true });
  private readonly msg = h("p.error", { role: "alert", "data-testid": "form-error" });

  constructor(
    readonly plant: PlantDetail,
    private readonly result: DesignResult,
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
    this.root = h(
      "form.panel",
      { novalidate: true, "aria-label": "design", onsubmit: (ev: Event) => (ev.preventDefault(), void this.compute()) },
      h("h2", "State feedback u = K (x_ref − x) on the physics model"),
      h("div.field", h("label", { for: "method" }, "Method"), this.method),
      this.lqrBox,
      this.placeBox,
      h("div.actions", h("button.primary", { type: "submit" }, "Design")),
      this.msg,
    );
  }

  private toggle(): void {
    const lqr = this.method.value === "lqr";
    this.lqrBox.hidden = !lqr;
    this.placeBox.hidden = lqr;
  }

  private async compute(): Promise<void> {
    fill(this.msg);
    const p = this.plant;
    const lqr = this.method.value === "lqr";
    const v = (lqr ? this.lqr : this.place).values();
    if (!v) return void fill(this.msg, "Please correct the marked fields; nothing was sent.");
    const title = lqr ? "LQR on the physics model" : "pole placement on the physics model";
    this.result.busy(title);
    try {
      const d = lqr
        ? await api.lqr(p.id, { Q: p.states.map((_, i) => v.get(`Q.${i}`)!) as LQRRequest["Q"], R: v.get("R")! })
        : await api.place(p.id, { poles: p.states.map((_, i) => ({ re: v.get(`poles.${i}.re`)!, im: v.get(`poles.${i}.im`)! })) as PlaceRequest["poles"] });
      await PhysicsDesign.show(p, this.result, d.K, title);
    } catch (err) {
      showApiError(err, [this.lqr, this.place], this.msg);
      this.result.failed(title, err);
    }
  }

  /** The loop of gain K with the predefined controller's state estimate (like with like),
   * beside the predefined controller's. */
  static async show(p: PlantDetail, result: DesignResult, K: number[], title: string): Promise<void> {
    const estimate = p.predefined.kind === "state_feedback" ? p.predefined.estimate : "true_state";
    const controller: StateFeedbackController = { kind: "state_feedback", K: K as StateFeedbackController["K"], estimate };
    const s = p.default_signal;
    const amplitude = "amplitude" in s && s.amplitude ? s.amplitude : 1;
    const [loop, step, compare] = await Promise.all([api.loop(p.id, { controller, amplitude }), api.step(p.id, { controller, amplitude }), api.step(p.id, { controller: { kind: "predefined" }, amplitude })]);
    const ref = p.outputs.find((o) => o.name === p.reference_output);
    result.show({
      title,
      K,
      details: [`u = K (x_ref − x̂), x̂ from ${estimate.replace(/_/g, " ")}, as the predefined controller's`],
      loop,
      step,
      compare,
      outputs: ref ? [{ name: ref.name, unit: ref.unit }] : [],
      controller,
      runTs: null,
      whyNot: null,
      domain: "s",
    });
  }

  static async byHand(p: PlantDetail, result: DesignResult, K: number[]): Promise<void> {
    const title = "K typed by hand on the physics model";
    result.busy(title);
    try {
      await PhysicsDesign.show(p, result, K, title);
    } catch (err) {
      result.failed(title, err);
      throw err;
    }
  }
}
