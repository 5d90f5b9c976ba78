import { describe, expect, it } from "vitest";
import { diffName, gapText, PredictionSeries } from "./prediction";
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
    notes: [],
  };
}

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
