import { describe, expect, it } from "vitest";
import { complexText, gainText, locusSeries, locusWindow, marginRows, peakText, verdictText } from "./designinfo";
import type { RootLocusOut } from "./protocol.gen";

describe("verdictText", () => {
  it("says unstable plainly", () => {
    const v = verdictText({ verdict: "unstable", reason: "pole 1.02 outside the unit circle (|z| > 1)" });
    expect(v.stable).toBe(false);
    expect(v.text).toContain("UNSTABLE");
    expect(v.text).toContain("pole 1.02");
    expect(verdictText({ verdict: "asymptotically stable", reason: "every pole inside" })).toEqual({ text: "Closed loop: stable (every pole inside).", stable: true });
    expect(verdictText({ verdict: "marginally stable", reason: "pole 0 on the axis" }).text).toContain("does not settle");
  });
});

describe("peakText", () => {
  it("warns when the peak passes the actuator limit", () => {
    const over = peakText({ peak_u: 45.3, u_max: 10, saturates: true }, "30°");
    expect(over.warn).toBe(true);
    expect(over.text).toContain("|u| = 45.3 V");
    expect(over.text).toContain("±10 V");
    expect(over.text).toContain("saturates");
    expect(peakText({ peak_u: 9.5, u_max: 10, saturates: false }, "30°")).toEqual({ text: "Predicted peak input for a step of r by 30°: |u| = 9.5 V, within the actuator's ±10 V.", warn: false });
    expect(peakText({ peak_u: null, u_max: 10, saturates: false }, "30°").warn).toBe(true);
  });
});

describe("numbers as printed", () => {
  it("writes gains, poles and margins", () => {
    expect(gainText([20, -93.5614, 3.3621, 0.9623])).toBe("K = [20, -93.5614, 3.3621, 0.9623]");
    expect(complexText({ re: -3.2, im: -4.1 })).toBe("−3.2 − 4.1j");
    expect(complexText({ re: 0.95, im: 0 })).toBe("0.95");
    expect(marginRows({ gain_margin_db: 6.02, phase_margin_deg: 45.1, gain_crossover: 12.5, phase_crossover: 30 })).toEqual([
      ["gain margin", "6.02 dB at ω = 30 rad/s"],
      ["phase margin", "45.1° at ω = 12.5 rad/s"],
    ]);
    expect(marginRows({ gain_margin_db: null, phase_margin_deg: null, gain_crossover: null, phase_crossover: null })[0][1]).toContain("∞");
  });
});

describe("locusSeries", () => {
  const rl: RootLocusOut = {
    domain: "z",
    gains: [0, 1, 1000],
    re: [
      [0.9, 0.5, 1e6],
      [1, 0.5, null],
    ],
    im: [
      [0, 0.2, 0],
      [0, -0.2, null],
    ],
    poles: [
      { re: 0.9, im: 0 },
      { re: 1, im: 0 },
    ],
    zeros: [],
  };
  const design = [
    { re: 0.5, im: 0.2 },
    { re: 0.5, im: -0.2 },
  ];
  it("draws every branch in one line, broken between branches and where it leaves the window", () => {
    const s = locusSeries(rl, design);
    expect(s.map((x) => x.name)).toEqual(["closed-loop poles, loop gain k from 0 to 1000", "open loop's poles (k = 0)", "the design's poles (k = 1)", "unit circle |z| = 1"]);
    expect(s[0].y).toEqual([0, 0.2, null, null, 0, -0.2, null, null]);
    expect(s[0].x.slice(0, 3)).toEqual([0.9, 0.5, NaN]);
    expect(s[2].mode).toBe("markers");
  });
  it("keeps the unit circle, the poles and the design in view", () => {
    const w = locusWindow(rl, design);
    expect(w.x[0]).toBeLessThan(-1);
    expect(w.x[1]).toBeGreaterThan(1);
    expect(w.y[1]).toBeGreaterThan(1);
  });
});
