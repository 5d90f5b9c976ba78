// What a live change altered, in the page's units: the server lists each value a change
// made (POST /runs/{id}/params → changed, SI), this says it in a sentence.
import type { ParamDiff, PlantDetail } from "./protocol.gen";
import { display, fmt } from "./units";

const SIGNAL_NAMES: Record<string, string> = { step: "step", square: "square wave", sine: "sine", chirp: "chirp", prbs: "PRBS", samples: "samples" };
const SIGNAL_FIELDS: Record<string, [string, string | null]> = {
  amplitude: ["amplitude", null],
  offset: ["offset", null],
  period: ["period", "s"],
  frequency: ["frequency", "Hz"],
  t0: ["step time", "s"],
  duty: ["duty cycle", ""],
  phase: ["phase", "rad"],
};

/** "reference amplitude 30 → 60 °; K1 20 → 30 V/rad" ("" when nothing changed). */
export function describeChanges(changed: ParamDiff[], plant: PlantDetail): string {
  return changed.map((d) => describeOne(d, plant, true)).join("; ");
}

/** Each value a change set, without what it was: ["K1 → 30 V/rad", "reference amplitude → 60°"]
 * (a mark's label on the plot; the table beside it has the whole sentence). */
export function changedTo(changed: ParamDiff[], plant: PlantDetail): string[] {
  return changed.map((d) => describeOne(d, plant, false));
}

function describeOne(d: ParamDiff, plant: PlantDetail, before: boolean): string {
  const [part, name, index] = d.field.split(".");
  if (part === "signal" && name === "kind") return `reference ${before ? `${signalName(d.before)} ` : ""}→ ${signalName(d.after)}`;
  if (part === "signal" && name in SIGNAL_FIELDS) {
    const [label, unit] = SIGNAL_FIELDS[name];
    const refUnit = plant.outputs.find((o) => o.name === plant.reference_output)?.unit ?? "";
    return `reference ${label} ${change(d, display(unit ?? refUnit), before)}`;
  }
  if (part === "controller" && name === "K" && index !== undefined) {
    const state = plant.states[Number(index)];
    const unit = `${plant.inputs[0]?.unit ?? "V"}/${state?.unit ?? "1"}`;
    return `K${Number(index) + 1} ${change(d, { unit, scale: 1 }, before)}`;
  }
  if (part === "controller" && ["Kp", "Ki", "Kd"].includes(name)) return `${name} ${change(d, { unit: "", scale: 1 }, before)}`;
  return `${d.field} ${change(d, { unit: "", scale: 1 }, before)}`;
}

function change(d: ParamDiff, unit: { unit: string; scale: number }, before: boolean): string {
  const text = (v: ParamDiff["before"]) => (typeof v === "number" ? fmt(v * unit.scale, 6) : v === null ? "none" : String(v));
  return `${before ? `${text(d.before)} ` : ""}→ ${text(d.after)}${unit.unit ? (unit.unit === "°" ? "°" : ` ${unit.unit}`) : ""}`;
}

function signalName(v: ParamDiff["before"]): string {
  return typeof v === "string" ? (SIGNAL_NAMES[v] ?? v) : "none";
}
