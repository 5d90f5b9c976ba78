import { describe, expect, it } from "vitest";
import { diffName, gapText, PredictionSeries, STEPS_SHOWN, stepTable } from "./prediction";
import type { PlantDetail, RunPrediction } from "./protocol.gen";
import { SampleRing } from "./series";

function prediction(n: number): RunPrediction {
  return {
    run_id: "r1",
    model: "the model",
    Ts: 0.001,
    n,
    compared: n,
    replayed: 0,
    diverged_at: null,
    channels: [
      { name: "u", unit: "V", label: "u", values: Array.from({ length: n }, (_, k) => k / 10) },
      { name: "theta", unit: "rad", label: "θ", values: Array.from({ length: n }, (_, k) => k) },
    ],
    gaps: [
      { name: "u", unit: "V", rms: 0.25, max_abs: 1, t_max: 0.02 },
      { name: "theta", unit: "rad", rms: Math.PI / 180, max_abs: Math.PI / 36, t_max: 1.5 },
    ],
    steps: [],
    notes: [],
  };
}

const info = (overshoot: number | null, settling: number | null, error: number) => ({ rise_time: 0.2, settling_time: settling, overshoot, peak: null, peak_time: null, steady_state: null, steady_state_error: error });

function run(k0: number, n: number, capacity = 100): SampleRing {
  const ring = new SampleRing(["r", "u", "theta", "alpha"], capacity);
  const col = (f: (k: number) => number) => Float32Array.from({ length: n }, (_, i) => f(k0 + i));
  ring.push(k0, n, { r: col(() => 0), u: col((k) => k / 10 + 1), theta: col((k) => 2 * k), alpha: col(() => 0) });
  return ring;
}

describe("PredictionSeries", () => {
  it("holds run − prediction for the samples the run has, as they come", () => {
    const s = new PredictionSeries(prediction(50), ["r", "u", "theta", "alpha"]);
    expect(s.names).toEqual(["u", "theta"]); // only channels both have
    const r = run(0, 20);
    expect(s.follow(r)).toBe(true);
    expect([s.ring.start, s.ring.end]).toEqual([0, 20]);
    expect(s.ring.at(diffName("theta"), 7)).toBe(7); // 2k − k
    expect(s.ring.at(diffName("u"), 7)).toBeCloseTo(1, 5);
    expect(s.ring.at("theta", 7)).toBe(7);
    expect(s.follow(r)).toBe(false); // nothing new
  });

  it("stops where the prediction ends and follows a recording cut short", () => {
    const s = new PredictionSeries(prediction(30), ["u", "theta"]);
    s.follow(run(0, 40));
    expect(s.ring.end).toBe(30); // a run longer than its prediction: compared as far as it goes
    const short = run(0, 12);
    expect(s.follow(short)).toBe(true);
    expect(s.ring.end).toBe(12);
  });

  it("starts where a late joiner's samples start", () => {
    const s = new PredictionSeries(prediction(80), ["u", "theta"]);
    s.follow(run(40, 10));
    expect([s.ring.start, s.ring.end, s.ring.at(diffName("theta"), 45)]).toEqual([40, 50, 45]);
  });
});

describe("gapText", () => {
  it("says each channel's gap in the page's units, the outputs first", () => {
    const plant = { outputs: [{ name: "theta", label: "θ", unit: "rad" }] } as unknown as PlantDetail;
    expect(gapText(prediction(10), plant)).toBe("Run − prediction over 10 samples: θ: RMS 1°, largest 5° at t = 1.5 s · u: RMS 0.25 V, largest 1 V at t = 0.02 s");
  });
});

describe("stepTable", () => {
  const plant = { outputs: [{ name: "theta", label: "θ", unit: "rad" }] } as unknown as PlantDetail;
  const step = (t: number) => ({ output: "theta", unit: "rad", t, span: 2, start: 0, target: Math.PI / 6, run: info(30, null, Math.PI / 180), prediction: info(4.5, 0.85, 0) });

  it("puts the run's characteristics beside the model's, in the page's units, with the difference", () => {
    const table = stepTable({ ...prediction(10), steps: [step(0)] }, plant)!;
    expect(table.querySelector("caption")?.textContent).toBe("Steps of the reference: θ, run / model (run − model)");
    expect(table.querySelector("tbody th")?.textContent).toBe("t = 0 s: 0° → 30°");
    const cell = (name: string) => table.querySelector(`td[data-characteristic="${name}"]`)?.textContent;
    expect(cell("overshoot")).toBe("30 % / 4.5 % (+25.5 %)");
    expect(cell("settling (2 %)")).toBe("not settled / 0.85 s");
    expect(cell("error at the end")).toBe("1° / 0° (+1°)");
    expect(cell("rise time")).toBe("0.2 s / 0.2 s (+0 s)");
  });

  it("shows the first steps and says how many more there are; none without steps", () => {
    const many = { ...prediction(10), steps: Array.from({ length: 8 }, (_, i) => step(2 * i)) };
    const table = stepTable(many, plant)!;
    expect(table.querySelectorAll("tbody tr")).toHaveLength(STEPS_SHOWN);
    expect(table.querySelector("p.note")?.textContent).toContain("and 3 more steps");
    expect(stepTable(prediction(10), plant)).toBeNull();
  });

  it("says — where a response had too few samples", () => {
    const table = stepTable({ ...prediction(10), steps: [{ ...step(0), run: null }] }, plant)!;
    expect(table.querySelector('td[data-characteristic="overshoot"]')?.textContent).toBe("— / 4.5 %");
  });
});
