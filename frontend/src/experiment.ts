// The forms every experiment shares: controller gains and the reference or excitation
// signal, with allowed ranges shown, values in display units (°, mm) and SI on the wire;
// how a run starts (private, and what becomes of the page's previous run).
import { api, ApiError } from "./api";
import { FieldSet, NumberField, type NumberSpec } from "./forms";
import { h } from "./dom";
import type { Controller, ControllerOut, PlantDetail, Signal, SignalOut } from "./protocol.gen";
import type { RunPanel } from "./runpanel";
import { display } from "./units";

export const GAIN_LIMIT = 1e6;
export const MAX_DURATION = 3600;
/** the server's least samples per run and per period (backend/elab/sim/spec.py) */
export const MIN_SAMPLES = 10;
export const MIN_PERIOD_SAMPLES = 4;

/** Gains of the plant's predefined controller (state feedback or PID) as fields. */
export class ControllerForm {
  readonly fields = new FieldSet();
  readonly root: HTMLElement;

  constructor(
    readonly plant: PlantDetail,
    readonly initial: ControllerOut = plant.predefined,
    onChange?: () => void,
  ) {
    const grid = h("div.grid");
    const gain = (spec: Omit<NumberSpec, "min" | "max">) =>
      grid.append(this.fields.add(new NumberField({ min: -GAIN_LIMIT, max: GAIN_LIMIT, step: "any", ...spec }, onChange)).root);
    if (initial.kind === "state_feedback") {
      const u = plant.inputs[0]?.unit ?? "V";
      initial.K.forEach((k, i) => {
        const st = plant.states[i];
        gain({ field: `controller.K.${i}`, label: `K${i + 1} · ${st?.label ?? `x${i + 1}`}`, unit: `${u}/${st?.unit ?? "1"}`, value: k });
      });
    } else if (initial.kind === "pid") {
      gain({ field: "controller.Kp", label: "Kp (proportional)", value: initial.Kp });
      gain({ field: "controller.Ki", label: "Ki (integral)", unit: "1/s", value: initial.Ki });
      gain({ field: "controller.Kd", label: "Kd (derivative)", unit: "s", value: initial.Kd });
    }
    this.root = h("fieldset.controller", h("legend", this.legend()), grid);
  }

  private legend(): string {
    const c = this.initial;
    if (c.kind === "state_feedback") return "State feedback u = K (x_ref − x̂)";
    if (c.kind === "pid") return "PID controller on e = r − y";
    return "Controller";
  }

  /** The controller to send, or null (each invalid field says why). */
  value(): Controller | null {
    const v = this.fields.values();
    if (!v) return null;
    const c = this.initial;
    if (c.kind === "state_feedback") return { kind: "state_feedback", K: c.K.map((_, i) => v.get(`controller.K.${i}`)!) as [number, ...number[]], estimate: c.estimate };
    if (c.kind === "pid") return { kind: "pid", Kp: v.get("controller.Kp")!, Ki: v.get("controller.Ki")!, Kd: v.get("controller.Kd")!, N: c.N, Tt: c.Tt };
    return { kind: "predefined" };
  }

  setGains(K: number[]): void {
    K.forEach((k, i) => {
      const f = this.fields.get(`controller.K.${i}`);
      if (f) f.value = Number(k.toPrecision(6));
    });
  }
}

export type SignalKind = "step" | "square" | "sine" | "prbs";

const SIGNAL_LABEL: Record<SignalKind, string> = { step: "step", square: "square wave", sine: "sine", prbs: "PRBS (pseudo-random binary)" };

/** A signal (reference or excitation) with its kind chosen from `kinds`. */
export class SignalForm {
  readonly root: HTMLElement;
  readonly fields = new FieldSet();
  readonly kind: HTMLSelectElement;
  private readonly body = h("div.grid");
  private readonly scale: number;
  private readonly unit: string;

  constructor(
    readonly prefix: "signal" | "excitation",
    readonly legend: string,
    readonly kinds: SignalKind[],
    /** SI unit of the signal (the reference output's, or the input's for excitation) */
    siUnit: string,
    readonly initial: SignalOut | null,
    private readonly onChange?: () => void,
    /** element id prefix, for a page with two signal forms (ids "own-signal-kind",
     * "own-signal-amplitude"; default "signal-kind", "f-signal-amplitude") */
    private readonly idPrefix?: string,
    /** the run's sample time (s): periods of at least MIN_PERIOD_SAMPLES samples */
    private readonly Ts?: number,
  ) {
    const d = display(siUnit);
    this.scale = d.scale;
    this.unit = d.unit;
    const kindId = idPrefix ? `${idPrefix}-${prefix}-kind` : `${prefix}-kind`;
    this.kind = h("select", { id: kindId, name: `${prefix}.kind`, onchange: () => this.build() }, ...kinds.map((k) => h("option", { value: k }, SIGNAL_LABEL[k])));
    if (initial && (kinds as string[]).includes(initial.kind)) this.kind.value = initial.kind;
    this.root = h("fieldset.signal", h("legend", legend), h("div.field", h("label", { for: kindId }, "Signal"), this.kind), this.body);
    this.build();
  }

  private amplitudeLimit(): number {
    return this.unit === "°" ? 360 : 1e4;
  }

  private build(): void {
    this.fields.fields.clear();
    this.body.replaceChildren();
    const kind = this.kind.value as SignalKind;
    const init = this.initial && this.initial.kind === kind ? this.initial : null;
    const p = this.prefix;
    const add = (spec: NumberSpec) => this.body.append(this.fields.add(new NumberField({ idPrefix: this.idPrefix, ...spec }, this.onChange)).root);
    const amp = init && "amplitude" in init ? init.amplitude * this.scale : this.unit === "°" ? 30 : 1;
    const lim = this.amplitudeLimit();
    add({ field: `${p}.amplitude`, label: "Amplitude", unit: this.unit, value: Number(amp.toPrecision(6)), min: -lim, max: lim });
    if (kind === "step") add({ field: `${p}.t0`, label: "Step time", unit: "s", value: init?.kind === "step" ? init.t0 : 0, min: 0, max: MAX_DURATION });
    const shortest = this.Ts ? Number((MIN_PERIOD_SAMPLES * this.Ts).toPrecision(12)) : 0;
    if (kind === "square") add({ field: `${p}.period`, label: "Period", unit: "s", value: init?.kind === "square" ? init.period : 4, min: shortest, minExclusive: !shortest, max: MAX_DURATION });
    if (kind === "sine") add({ field: `${p}.frequency`, label: "Frequency", unit: "Hz", value: init?.kind === "sine" ? init.frequency : 0.5, min: 0, minExclusive: true, max: shortest ? Number((1 / shortest).toPrecision(12)) : 500 });
    if (p === "signal" && kind !== "prbs") add({ field: `${p}.offset`, label: "Offset", unit: this.unit, value: init && "offset" in init ? Number((init.offset * this.scale).toPrecision(6)) : 0, min: -lim, max: lim });
    if (kind === "prbs") {
      add({ field: `${p}.band`, label: "Band (fraction of Nyquist)", value: init?.kind === "prbs" ? init.band : 0.05, min: 1e-6, max: 1 });
      add({ field: `${p}.order`, label: "Register length", value: init?.kind === "prbs" ? init.order : 10, min: 3, max: 20, integer: true, hint: "allowed: a whole number 3 … 20 (period 2ⁿ − 1 bits)" });
    }
    this.onChange?.();
  }

  value(): Signal | null {
    const v = this.fields.values();
    if (!v) return null;
    const p = this.prefix;
    const amplitude = v.get(`${p}.amplitude`)! / this.scale;
    const offset = (v.get(`${p}.offset`) ?? 0) / this.scale;
    switch (this.kind.value as SignalKind) {
      case "step":
        return { kind: "step", amplitude, t0: v.get(`${p}.t0`)!, offset };
      case "square":
        return { kind: "square", amplitude, period: v.get(`${p}.period`)!, offset };
      case "sine":
        return { kind: "sine", amplitude, frequency: v.get(`${p}.frequency`)!, offset };
      case "prbs":
        return { kind: "prbs", amplitude, band: v.get(`${p}.band`)!, order: v.get(`${p}.order`)! };
    }
  }
}

/** The run length field (`Ts`: the run's sample time; a run has at least MIN_SAMPLES). */
export function durationField(value: number, onChange?: () => void, idPrefix?: string, Ts?: number): NumberField {
  const min = Ts ? Number((MIN_SAMPLES * Ts).toPrecision(12)) : 0;
  return new NumberField({ field: "duration", label: "Duration", unit: "s", value, min, minExclusive: !min, max: MAX_DURATION, idPrefix }, onChange);
}

/** Where a run starts: a field per state the plant lets a run choose (its
 * initial_state_ranges), absolute, in display units; pre-filled with the state the plant's
 * analysis experiment starts from. A plant without such states has no form (`root` null). */
export class InitialStateForm {
  readonly fields = new FieldSet();
  readonly root: HTMLElement | null = null;
  private readonly start: number[];

  constructor(readonly plant: PlantDetail) {
    this.start = [...(plant.default_x0 ?? plant.operating_point)];
    const ranges = plant.initial_state_ranges as [string, number, number][];
    if (!ranges.length) return;
    const grid = h("div.grid");
    const round = (x: number) => Number(x.toPrecision(10)); // as value() reads it back
    for (const [name, lo, hi] of ranges) {
      const i = plant.states.findIndex((st) => st.name === name);
      const st = plant.states[i];
      const d = display(st.unit);
      grid.append(this.fields.add(new NumberField({ field: `x0.${i}`, label: st.label, unit: d.unit, value: round(this.start[i] * d.scale), min: round(lo * d.scale), max: round(hi * d.scale) })).root);
    }
    this.root = h("fieldset.initial-state", h("legend", "Start from"), grid, h("small.hint", "Where the run starts (absolute). The linear model holds within the allowed ranges; every other state starts at the operating point."));
  }

  /** The absolute initial state to send; undefined when the plant offers no choice, null
   * while a field is invalid. */
  value(): number[] | null | undefined {
    if (!this.root) return undefined;
    const v = this.fields.values();
    if (!v) return null;
    return this.start.map((x, i) => {
      const typed = v.get(`x0.${i}`);
      const scale = display(this.plant.states[i].unit).scale;
      return typed === undefined || typed === Number((x * scale).toPrecision(10)) ? x : typed / scale; // untouched: exactly the plant's
    });
  }

  set disabled(off: boolean) {
    for (const f of this.fields.fields.values()) f.disabled = off;
  }
}

/** "Private run" and "Keep my previous run going": how the next run starts. */
export class StartOptions {
  readonly root: HTMLElement;
  private readonly privateBox: HTMLInputElement;
  private readonly keepBox: HTMLInputElement;

  constructor(idPrefix = "start") {
    this.privateBox = h("input", { type: "checkbox", id: `${idPrefix}-private`, name: "private" });
    this.keepBox = h("input", { type: "checkbox", id: `${idPrefix}-keep`, name: "keep" });
    this.root = h(
      "div.start-options",
      h("label.check", { title: "Only you and instructors may see it; others cannot open its link." }, this.privateBox, " Private run"),
      h("label.check", { title: "Otherwise Start stops this page's previous run if it is still going." }, this.keepBox, " Keep my previous run going"),
    );
  }

  get private(): boolean {
    return this.privateBox.checked;
  }

  /** Stop the page's previous run (or the run drawn over it) once a new one has started:
   * if it is yours, still live, and not to be kept going. */
  async retire(previous: Pick<RunPanel, "live" | "run"> | null): Promise<void> {
    if (!previous || this.keepBox.checked || !previous.live || !previous.run.mine) return;
    try {
      await api.stop(previous.run.id);
    } catch (err) {
      if (err instanceof ApiError && err.status === 409) return; // it ended meanwhile
      throw err;
    }
  }
}
