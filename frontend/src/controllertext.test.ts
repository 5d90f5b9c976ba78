import { describe, expect, it } from "vitest";
import { amountText, complexText, computeText, formatText, LATE_NOT_SLOW, lawText, marginText, peakText, poleList, verdictText, verdictWord } from "./controllertext";

describe("lawText", () => {
  it("writes state feedback as K = [...] with its estimate", () => {
    const t = lawText({ kind: "state_feedback", K: [15, -93.5614, 3.3621, 0.9623], estimate: "velocity_filters", Nr: null, L: null, observer_poles: null });
    expect(t.law).toBe("K = [15, -93.5614, 3.3621, 0.9623]");
    expect(t.kind).toMatch(/^state feedback u = K \(x_ref − x̂\), x̂ from measured positions and filtered velocities$/);
    expect(lawText({ kind: "state_feedback", K: [1], estimate: "true_state", Nr: null, L: null, observer_poles: null }).kind).toMatch(/true \(simulated\) state/);
    const obs = lawText({ kind: "state_feedback", K: [1, 2], estimate: "observer", Nr: 3, L: null, observer_poles: [{ re: -40, im: 5 }, { re: -40, im: -5 }] });
    expect(obs.kind).toBe("state feedback u = Nr r − K x̂, x̂ from a Luenberger observer on the model");
    expect(obs.law).toBe("K = [1, 2], Nr = 3, observer poles -40 ± 5j");
  });

  it("writes a PID as Kp, Ki, Kd and N, and Tt when it is given", () => {
    expect(lawText({ kind: "pid", Kp: 12, Ki: 0.49, Kd: 0.5, N: 10, Tt: null, b: 1, c: 1 }).law).toBe("Kp = 12, Ki = 0.49, Kd = 0.5, N = 10");
    expect(lawText({ kind: "pid", Kp: 1, Ki: 0.05, Kd: 0, N: 10, Tt: 2.5, b: 1, c: 1 }).law).toBe("Kp = 1, Ki = 0.05, Kd = 0, N = 10, Tt = 2.5 s");
    expect(lawText({ kind: "pid", Kp: 1, Ki: 0, Kd: 0, N: 10, Tt: null, b: 0.5, c: 0 }).law).toBe("Kp = 1, Ki = 0, Kd = 0, N = 10, b = 0.5, c = 0");
  });

  it("writes an LTI controller as num/den or A, B, C, D, continuous or discrete", () => {
    const tf = lawText({ kind: "lti", num: [1, 2], den: [1, 0.5], A: null, B: null, C: null, D: null, dt: 0.001, ff_num: null, ff_den: null, B_r: null, D_r: null });
    expect(tf).toEqual({ kind: "LTI controller on e = r − y, discrete, dt = 1 ms", law: "num = [1, 2], den = [1, 0.5]" });
    const ss = lawText({ kind: "lti", num: null, den: null, A: [[-1, 0], [0, -2]], B: [[1], [1]], C: [[3, 4]], D: [[0]], dt: null, ff_num: [1], ff_den: [0.1, 1], B_r: null, D_r: null });
    expect(ss.kind).toMatch(/continuous/);
    expect(ss.law).toBe("A = [-1, 0; 0, -2], B = [1; 1], C = [3, 4], D = [0]; feed-forward ff_num = [1], ff_den = [0.1, 1]");
    const twoDof = lawText({ kind: "lti", num: null, den: null, A: [[0.5]], B: [[-1]], C: [[2]], D: [[0]], dt: 0.001, ff_num: null, ff_den: null, B_r: [[1.5]], D_r: [[3]] });
    expect(twoDof.law).toBe("A = [0.5], B = [-1], C = [2], D = [0]; reference input B_r = [1.5], D_r = [3]");
  });

  it("names open loop and the predefined controller", () => {
    expect(lawText({ kind: "open_loop" })).toEqual({ kind: "open loop", law: "u = r" });
    expect(lawText({ kind: "predefined" }).law).toBe("");
  });
});

describe("poles", () => {
  it("writes a complex pole with its sign, a real one alone", () => {
    expect(complexText({ re: -83.49080338952992, im: -179.186027280959 })).toBe("-83.49 − 179.2j");
    expect(complexText({ re: 0.99, im: 0.004 })).toBe("0.99 + 0.004j");
    expect(complexText({ re: -10.450636722952373, im: 0 })).toBe("-10.45");
  });

  it("lists each conjugate pair once, in the report's order", () => {
    const poles = [
      { re: -83.49080338952992, im: -179.186027280959 },
      { re: -83.49080338952992, im: 179.186027280959 },
      { re: -10.45, im: 0 },
      { re: -5.36, im: 6.64 },
      { re: -5.36, im: -6.64 },
      { re: -1, im: 2 }, // no partner: shown as it is
    ];
    expect(poleList(poles)).toEqual(["-83.49 ± 179.2j", "-10.45", "-5.36 ± 6.64j", "-1 + 2j"]);
  });
});

describe("verdictText", () => {
  it("says where the poles are, in s or in z", () => {
    expect(verdictText({ stable: true, domain: "s" })).toMatch(/^stable: .*negative real part/);
    expect(verdictText({ stable: false, domain: "s" })).toMatch(/^unstable/);
    expect(verdictText({ stable: true, domain: "z" })).toMatch(/^stable: .*inside the unit circle/);
    expect(verdictText({ stable: false, domain: "z" })).toMatch(/^unstable: .*outside the unit circle/);
  });

  it("says whether a Python controller's trial runs ran through", () => {
    expect(verdictText({ stable: true, domain: "trial" })).toMatch(/^ran through: /);
    expect(verdictText({ stable: false, domain: "trial" })).toMatch(/^failed: .*problems below/);
    expect([true, false].flatMap((stable) => (["s", "z", "trial"] as const).map((domain) => verdictWord({ stable, domain })))).toEqual(["stable", "stable", "ran through", "unstable", "unstable", "failed"]);
  });
});

describe("computeText", () => {
  it("writes a Python controller's compute time per step in µs, and how many were late", () => {
    const c = { steps: 20000, median_us: 41.23, p99_us: 88.14, max_us: 1234.5, round_trip_median_us: 120.4, round_trip_p99_us: 250, misses: 3, slow: 0 };
    expect(computeText(c)).toBe("Compute time per step: median 41.2 µs, p99 88.1 µs (max 1230 µs); round trip median 120 µs, p99 250 µs; 3 late of 20,000 steps" + LATE_NOT_SLOW);
    expect(computeText({ ...c, slow: 2 })).toMatch(/3 late of 20,000 steps, 2 of them slower than the deadline in the controller itself$/);
    expect(computeText({ ...c, slow: 0 })).toBe(computeText(c));
    expect(computeText(c)).toMatch(/3 late of 20,000 steps, none of them slow in the controller itself: the machine was busy/);
    expect(computeText({ ...c, misses: 0, slow: 0 })).toMatch(/0 late of 20,000 steps$/);
  });
});

describe("formatText", () => {
  it("names Python; other formats by their extension", () => {
    expect(formatText("py")).toBe("Python (py)");
    expect(formatText("toml")).toBe("toml");
  });
});

describe("marginText", () => {
  it("writes a missing margin as infinite", () => {
    expect(marginText({ gain_margin_db: null, phase_margin_deg: 47.96040578450891 })).toEqual({ gain: "∞", phase: "48°" });
    expect(marginText({ gain_margin_db: 27.824087894936618, phase_margin_deg: null })).toEqual({ gain: "27.8 dB", phase: "∞" });
  });
});

describe("peakText", () => {
  it("gives the step in display units (° for rad) and the peak against the limit", () => {
    const flex = peakText({ peak_u: 7.853981633974482, u_max: 10, step_amplitude: 0.5235987755982988 }, "rad");
    expect(flex).toEqual({ text: "7.854 V within ±10 V for a step of 30°", over: false });
    const belt = peakText({ peak_u: 66, u_max: 10, step_amplitude: 0.5 }, "m");
    expect(belt).toEqual({ text: "66 V beyond ±10 V for a step of 500 mm", over: true });
    expect(peakText({ peak_u: -12, u_max: 10, step_amplitude: 1 }, "").over).toBe(true);
    expect(peakText({ peak_u: null, u_max: 10, step_amplitude: Math.PI / 6 }, "rad")).toEqual({ text: "none for a step of 30°: the loop is unstable, u grows until it saturates at ±10 V", over: true });
  });

  it("writes amounts in the unit people read", () => {
    expect(amountText(Math.PI / 6, "rad")).toBe("30°");
    expect(amountText(0.5, "m")).toBe("500 mm");
    expect(amountText(2, "")).toBe("2");
  });
});
