import { describe, expect, it } from "vitest";
import type { PlantDetail } from "./protocol.gen";
import { outputAxes } from "./runpanel";

const LABELS: Record<string, string> = { alpha: "disc angle α", beta1: "pendulum 1 angle β₁ from upright", beta2: "pendulum 2 angle β₂ from upright" };
const plant = (op: number[], C: number[][], outputs: string[], ref: string, ranges: string[] = []) =>
  ({
    C,
    operating_point: op,
    outputs: outputs.map((name) => ({ name, label: LABELS[name] ?? name, unit: "rad" })),
    inputs: [{ name: "u", label: "u", unit: "V" }],
    reference_output: ref,
    initial_state_ranges: ranges.map((name) => [name, -0.17, 0.17]),
  }) as unknown as PlantDetail;

describe("outputAxes", () => {
  it("gives an output that sits at 180° its own axes (issue 15: β₂ flattened α and β₁)", () => {
    const p = plant([0, 0, Math.PI, 0, 0, 0], [[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0]], ["alpha", "beta1", "beta2"], "alpha");
    const { axis, titles } = outputAxes(p);
    expect([axis.get("alpha"), axis.get("beta1"), axis.get("r"), axis.get("beta2"), axis.get("u")]).toEqual([1, 1, 1, 2, 3]);
    expect(titles).toEqual(["α, β₁ (°)", "β₂ (°)", "u (V)"]);
  });
  it("gives an output valid only in a narrow range its own axes, titled with the legend's symbol (issue 27)", () => {
    const p = plant([0, 0, Math.PI, 0, 0, 0], [[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0]], ["alpha", "beta1", "beta2"], "alpha", ["beta1", "beta2"]);
    const { axis, titles } = outputAxes(p);
    expect([axis.get("alpha"), axis.get("r"), axis.get("beta1"), axis.get("beta2"), axis.get("u")]).toEqual([1, 1, 2, 3, 4]);
    expect(titles).toEqual(["α (°)", "β₁ (°)", "β₂ (°)", "u (V)"]);
  });
  it("keeps one outputs' axes when every output is about zero", () => {
    const { axis, titles } = outputAxes(plant([0, 0, 0, 0], [[1, 0, 0, 0], [0, 1, 0, 0]], ["theta", "alpha"], "theta"));
    expect([axis.get("theta"), axis.get("alpha"), axis.get("u")]).toEqual([1, 1, 2]);
    expect(titles).toEqual(["outputs (°)", "u (V)"]);
  });
});

describe("channelColor", () => {
  it("gives each signal one colour on every plot of a plant (issue 15)", async () => {
    const { channelColor } = await import("./plot");
    const outs = ["alpha", "beta1", "beta2"];
    expect(channelColor("r", outs)).toBe(channelColor("r", ["theta"]));
    expect(channelColor("u", outs)).not.toBe(channelColor("r", outs));
    const colours = outs.map((o) => channelColor(o, outs));
    expect(new Set(colours).size).toBe(3);
    expect(colours).not.toContain(channelColor("u", outs));
    expect(channelColor("nothing", outs)).toBeUndefined();
  });
});
