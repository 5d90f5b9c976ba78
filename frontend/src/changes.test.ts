import { describe, expect, it } from "vitest";
import { describeChanges } from "./changes";
import type { PlantDetail } from "./protocol.gen";

const plant = {
  reference_output: "theta",
  outputs: [{ name: "theta", unit: "rad", label: "servo angle θ" }],
  states: [
    { name: "theta", unit: "rad", label: "θ" },
    { name: "alpha", unit: "rad", label: "α" },
  ],
  inputs: [{ name: "u", unit: "V", label: "u" }],
} as unknown as PlantDetail;

describe("describeChanges", () => {
  it("says each changed value in the page's units", () => {
    const text = describeChanges(
      [
        { field: "signal.amplitude", before: Math.PI / 6, after: Math.PI / 3 },
        { field: "signal.period", before: 4, after: 2 },
        { field: "controller.K.1", before: -93.5614, after: -80 },
      ],
      plant,
    );
    expect(text).toBe("reference amplitude 30 → 60°; reference period 4 → 2 s; K2 -93.5614 → -80 V/rad");
  });

  it("names a new signal kind and values that were not set", () => {
    expect(describeChanges([{ field: "signal.kind", before: "square", after: "sine" }, { field: "signal.frequency", before: null, after: 0.5 }], plant)).toBe("reference square wave → sine; reference frequency none → 0.5 Hz");
    expect(describeChanges([], plant)).toBe("");
  });
});
