// A run's settings (its request, SI on the wire) as a table people read: the controller's
// gains as the form labels them, the reference in degrees where the plant's unit is rad,
// what the sensors and the amplifier did, where the run started.
import type { PlantDetail, RunInfo } from "./protocol.gen";
import { fmt, quantity } from "./units";

export interface SettingsSection {
  title: string;
  rows: [string, string][];
}

type Json = Record<string, unknown>;

const SIGNALS: Record<string, string> = { step: "step", square: "square wave", sine: "sine", chirp: "chirp (frequency sweep)", prbs: "PRBS (pseudo-random binary)", samples: "samples (given values)" };
const ESTIMATES: Record<string, string> = { velocity_filters: "velocity filters (rates from the measured angles)", observer: "observer", true_state: "the true state (simulation only)" };

const num = (v: unknown): number | null => (typeof v === "number" ? v : null);
const list = (v: unknown): string => (Array.isArray(v) ? `[${v.map((x) => (typeof x === "number" ? fmt(x) : String(x))).join(", ")}]` : "—");

/** The rows of a signal (reference or excitation) whose amplitude is in `unit` (SI). */
export function signalRows(signal: Json, unit: string): [string, string][] {
  const kind = String(signal.kind);
  const rows: [string, string][] = [["signal", SIGNALS[kind] ?? kind]];
  const add = (label: string, v: unknown, u: string) => {
    if (typeof v === "number") rows.push([label, quantity(v, u)]);
  };
  if (kind === "samples") rows.push(["values", `${Array.isArray(signal.values) ? signal.values.length : 0} samples`]);
  add("amplitude", signal.amplitude, unit);
  add("offset", signal.offset, unit);
  add("step time", signal.t0, "s");
  add("period", signal.period, "s");
  if (typeof signal.duty === "number") rows.push(["duty cycle", `${fmt(signal.duty * 100)} %`]);
  add("frequency", signal.frequency, "Hz");
  add("phase", signal.phase, "rad");
  add("start frequency", signal.f0, "Hz");
  add("end frequency", signal.f1, "Hz");
  add("sweep time", signal.sweep, "s");
  if (typeof signal.order === "number") rows.push(["register length", `${signal.order} bits`]);
  if (typeof signal.band === "number") rows.push(["band", `${fmt(signal.band)} of the Nyquist frequency`]);
  return rows;
}

/** The rows of a controller (the predefined one as the plant's gains). */
export function controllerRows(controller: Json, plant: PlantDetail): [string, string][] {
  const u = plant.inputs[0]?.unit ?? "V";
  const ref = plant.outputs.find((o) => o.name === plant.reference_output)?.unit ?? "";
  if (controller.kind === "predefined") return [["controller", `the plant's predefined: ${plant.predefined_design}`], ...controllerRows(plant.predefined as unknown as Json, plant).filter(([k]) => k !== "controller")];
  switch (controller.kind) {
    case "state_feedback": {
      const K = Array.isArray(controller.K) ? (controller.K as number[]) : [];
      const rows: [string, string][] = [["controller", "state feedback u = K (x_ref − x̂)"]];
      K.forEach((k, i) => rows.push([`K${i + 1} · ${plant.states[i]?.label ?? `state ${i + 1}`}`, `${fmt(k, 6)} ${u}/${plant.states[i]?.unit ?? "1"}`]));
      if (typeof controller.estimate === "string") rows.push(["state estimate", ESTIMATES[controller.estimate] ?? controller.estimate]);
      if (num(controller.Nr) !== null) rows.push(["reference gain Nr", fmt(num(controller.Nr), 6)]);
      return rows;
    }
    case "pid": {
      const rows: [string, string][] = [["controller", "PID"]];
      const gain = (label: string, v: unknown, unit: string) => num(v) !== null && rows.push([label, `${fmt(num(v), 6)} ${unit}`]);
      gain("Kp", controller.Kp, `${u}/${ref}`);
      gain("Ki", controller.Ki, `${u}/(${ref}·s)`);
      gain("Kd", controller.Kd, `${u}·s/${ref}`);
      gain("derivative filter N", controller.N, "");
      gain("anti-windup Tt", controller.Tt, "s");
      gain("set-point weight b", controller.b, "");
      gain("set-point weight c", controller.c, "");
      return rows.map(([k, v]) => [k, v.trim()]);
    }
    case "lti":
      return Array.isArray(controller.num)
        ? [["controller", "transfer function"], ["numerator", list(controller.num)], ["denominator", list(controller.den)], ...(num(controller.dt) !== null ? [["sample time", quantity(num(controller.dt), "s")] as [string, string]] : [])]
        : [["controller", `state space, ${Array.isArray(controller.A) ? controller.A.length : 0} states`]];
    case "open_loop":
      return [["controller", "none: open loop"]];
    default:
      return [["controller", String(controller.kind)]];
  }
}

function sensorRows(req: Json, run: RunInfo, plant: PlantDetail): [string, string][] {
  // the server's defaults (RunCreate): noise and quantisation on for identification runs,
  // noise also whenever a seed is given; the plant's own input limit
  const ident = run.experiment === "identification";
  const given = (v: unknown) => (typeof v === "boolean" ? v : null);
  const noise = given(req.noise) ?? (typeof req.seed === "number" || ident);
  const quantize = given(req.quantize) ?? ident;
  const saturate = given(req.saturate) ?? plant.saturate;
  return [
    ["sensor noise", noise ? `on${typeof req.seed === "number" ? ` (seed ${req.seed})` : ""}` : "off"],
    ["quantisation", quantize ? "on (the sensors' resolution)" : "off"],
    ["input limit", saturate ? `±${fmt(plant.u_max)} ${plant.inputs[0]?.unit ?? "V"}` : "off"],
  ];
}

/** The run's settings in sections, in the page's units. */
export function runSettings(run: RunInfo, plant: PlantDetail): SettingsSection[] {
  const req: Json = run.request;
  const refOut = plant.outputs.find((o) => o.name === plant.reference_output);
  const sections: SettingsSection[] = [];
  const controller = (req.controller as Json | undefined) ?? { kind: "predefined" };
  const rows = controllerRows(controller, plant);
  if (typeof req.controller_id === "string") rows.unshift(["uploaded controller", req.controller_id]);
  sections.push({ title: "Controller", rows });
  const signal = (req.signal as Json | null | undefined) ?? (plant.default_signal as unknown as Json);
  sections.push({ title: `Reference for ${refOut?.label ?? plant.reference_output}`, rows: signalRows(signal, refOut?.unit ?? "") });
  if (req.excitation) {
    const atInput = req.excitation_at !== "reference";
    sections.push({ title: "Excitation", rows: [["added to", atInput ? "the control signal u" : "the reference"], ...signalRows(req.excitation as Json, atInput ? (plant.inputs[0]?.unit ?? "V") : (refOut?.unit ?? ""))] });
  }
  const general: [string, string][] = [
    ["mode", run.mode],
    ["experiment", run.experiment],
    ["duration", `${fmt(run.n_planned * run.Ts)} s (${run.n_planned.toLocaleString("en")} samples)`],
    ["sample time", quantity(run.Ts * 1000, "ms")],
    ["pace", req.pace === "fast" ? "as fast as possible" : "real time"],
    ["visible to", req.private ? "its owner and instructors" : "anyone with the link"],
  ];
  sections.push({ title: "Run", rows: general }, { title: "Sensors and amplifier", rows: sensorRows(req, run, plant) });
  if (Array.isArray(req.x0)) sections.push({ title: "Start from", rows: (req.x0 as number[]).map((x, i) => [plant.states[i]?.label ?? `x${i + 1}`, quantity(x, plant.states[i]?.unit ?? "")]) });
  else if ((plant.initial_state_ranges as unknown[] | undefined)?.length) sections.push({ title: "Start from", rows: [["state", "the operating point"]] });
  return sections;
}
