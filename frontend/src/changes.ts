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
  return changed.map((d) => describeOne(d, plant)).join("; ");
}

function describeOne(d: ParamDiff, plant: PlantDetail): string {
  const [part, name, index] = d.field.split(".");
  if (part === "signal" && name === "kind") return `reference ${signalName(d.before)} → ${signalName(d.after)}`;
  if (part === "signal" && name in SIGNAL_FIELDS) {
    const [label, unit] = SIGNAL_FIELDS[name];
    const refUnit = plant.outputs.find((o) => o.name === plant.reference_output)?.unit ?? "";
    return `reference ${label} ${change(d, display(unit ?? refUnit))}`;
  }
  if (part === "controller" && name === "K" && index !== undefined) {
    const state = plant.states[Number(index)];
    const unit = `${plant.inputs[0]?.unit ?? "V"}/${state?.unit ?? "1"}`;
    return `K${Number(index) + 1} ${change(d, { unit, scale: 1 })}`;
  }
  if (part === "controller" && ["Kp", "Ki", "Kd"].includes(name)) return `${name} ${change(d, { unit: "", scale: 1 })}`;
  return `${d.field} ${change(d, { unit: "", scale: 1 })}`;
}

function change(d: ParamDiff, unit: { unit: string; scale: number }): string {
  const text = (v: ParamDiff["before"]) => (typeof v === "number" ? fmt(v * unit.scale, 6) : v === null ? "none" : String(v));
  return `${text(d.before)} → ${text(d.after)}${unit.unit ? (unit.unit === "°" ? "°" : ` ${unit.unit}`) : ""}`;
}

function signalName(v: ParamDiff["before"]): string {
  return typeof v === "string" ? (SIGNAL_NAMES[v] ?? v) : "none";
}
