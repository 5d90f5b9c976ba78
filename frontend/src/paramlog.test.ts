import { describe, expect, it } from "vitest";
import { diffParams, markLabel, ParamLog } from "./paramlog";
import type { PlantDetail } from "./protocol.gen";

// the flexible link as GET /plants/flexible_link gives it (the fields the log reads)
const plant = {
  reference_output: "theta",
  outputs: [{ name: "theta", unit: "rad", label: "servo angle θ" }],
  states: [
    { name: "theta", unit: "rad", label: "servo angle θ" },
    { name: "alpha", unit: "rad", label: "link deflection α" },
    { name: "theta_dot", unit: "rad/s", label: "servo speed θ̇" },
    { name: "alpha_dot", unit: "rad/s", label: "deflection rate α̇" },
  ],
  inputs: [{ name: "u", unit: "V", label: "motor voltage u" }],
  predefined: { kind: "state_feedback", K: [20, -93.5614, 3.3621, 0.9623], estimate: "velocity_filters", Nr: null, L: null, observer_poles: null },
  default_signal: { kind: "square", amplitude: Math.PI / 6, period: 4, offset: 0, duty: 0.5 },
} as unknown as PlantDetail;

const square = (amplitude: number) => ({ kind: "square", amplitude, period: 4, offset: 0, duty: 0.5 });
const gains = (K: number[]) => ({ kind: "state_feedback", K, estimate: "velocity_filters", Nr: null, L: null, observer_poles: null });

describe("diffParams", () => {
  it("lists the values that differ, by path, numbers to 12 digits", () => {
    expect(diffParams("signal", square(0.5), { ...square(0.5 * (1 + 1e-14)), period: 2 })).toEqual([{ field: "signal.period", before: 4, after: 2 }]);
    expect(diffParams("controller", gains([1, 2]), gains([1, 3]))).toEqual([{ field: "controller.K.1", before: 2, after: 3 }]);
  });

  it("keeps what only the old value had, as no longer set", () => {
    expect(diffParams("signal", square(1), { kind: "sine", amplitude: 1, frequency: 0.5, offset: 0 })).toEqual([
      { field: "signal.kind", before: "square", after: "sine" },
      { field: "signal.frequency", before: null, after: 0.5 },
      { field: "signal.period", before: 4, after: null },
      { field: "signal.duty", before: 0.5, after: null },
    ]);
  });
});

describe("ParamLog", () => {
  it("says what each change altered against the run's settings just before it", () => {
    const log = new ParamLog({ controller: { kind: "predefined" }, signal: square(Math.PI / 6) }, plant);
    const first = log.add({ k: 2000, t: 2, params: { controller: gains([30, -93.5614, 3.3621, 0.9623]) } })!;
    expect(first.text).toBe("K1 20 → 30 V/rad"); // the predefined controller is the plant's gains
    const second = log.add({ k: 5000, t: 5, params: { controller: gains([30, -93.5614, 3.3621, 0.9623]), signal: square(Math.PI / 3) } })!;
    expect(second.text).toBe("reference amplitude 30 → 60°"); // K1 was 30 already
    expect(log.entries.map((e) => e.k)).toEqual([2000, 5000]);
  });

  it("keeps a change once when the record and the stream both bring it", () => {
    const log = new ParamLog({ signal: square(1) }, plant);
    const change = { k: 10, t: 0.01, params: { signal: square(2) } };
    expect(log.add(change)).not.toBeNull();
    expect(log.add({ ...change })).toBeNull();
    expect(log.entries).toHaveLength(1);
  });

  it("names an uploaded controller and says when nothing differed", () => {
    const log = new ParamLog({}, plant);
    expect(log.add({ k: 1, t: 0.001, params: { controller: gains([20, -93.5614, 3.3621, 0.9623]), controller_id: "c-42" } })!.text).toBe("controller c-42");
    expect(log.add({ k: 2, t: 0.002, params: { signal: plant.default_signal } })!.text).toBe("the same values again");
  });

  it("labels a mark with whole values only, and counts those that do not fit", () => {
    expect(markLabel(["K1 → 30 V/rad"])).toBe("K1 → 30 V/rad");
    expect(markLabel(["K1 → 30 V/rad", "reference amplitude → 60°"])).toBe("K1 → 30 V/rad, reference amplitude → 60°");
    expect(markLabel(["K1 → 30 V/rad", "K2 → -93.5614 V/(rad/s)", "reference amplitude → 60°"])).toBe("K1 → 30 V/rad, +2 more");
    expect(markLabel(["x".repeat(50)])).toBe("1 change");
    expect(markLabel(["x".repeat(50), "K1 → 3"])).toBe("2 changes");
    for (const n of [1, 2, 5, 12]) {
      const parts = Array.from({ length: n }, (_, i) => `K${i + 1} → ${-93.5614 * (i + 1)} V/rad`);
      const label = markLabel(parts);
      expect(label.length).toBeLessThanOrEqual(40);
      // every number shown is whole: each shown part is one of the parts
      for (const shown of label.split(", ").filter((p) => !p.startsWith("+"))) expect(parts).toContain(shown);
    }
  });

  it("gives each change a label of what it set", () => {
    const log = new ParamLog({ signal: square(1) }, plant);
    const e = log.add({ k: 10, t: 0.01, params: { signal: square(2), controller: gains([30, -93.5614, 3.3621, 0.9623]) } })!;
    expect(e.text).toContain("→");
    expect(e.label.length).toBeLessThanOrEqual(40);
    expect(e.label).not.toContain("…");
  });
});
