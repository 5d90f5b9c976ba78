// An uploaded controller in words: its law (K = […], Kp/Ki/Kd, num/den or A, B, C, D) and
// its report (verdict, closed-loop poles, margins, the peak control against the actuator;
// for a Python controller its trial and compute time per step), with the reference in
// display units (° for a plant whose output is in rad).
import type { Complex, ComputeTimes, ControllerOut, ControllerReportOut } from "./protocol.gen";
import { display, fmt } from "./units";

const vector = (xs: number[]) => `[${xs.map((x) => fmt(x, 6)).join(", ")}]`;
const matrix = (m: number[][]) => `[${m.map((row) => row.map((x) => fmt(x, 6)).join(", ")).join("; ")}]`;

export interface LawText {
  /** what kind of law, in words */
  kind: string;
  /** its numbers, e.g. "K = [20, -93.5614, 3.3621, 0.9623]" */
  law: string;
}

/** A controller's law as people read it. */
export function lawText(c: ControllerOut): LawText {
  switch (c.kind) {
    case "state_feedback": {
      const estimate = {
        velocity_filters: "from measured positions and filtered velocities",
        true_state: "the true (simulated) state",
        observer: "from a Luenberger observer on the model",
      }[c.estimate];
      const form = c.Nr === null ? "u = K (x_ref − x̂)" : "u = Nr r − K x̂";
      const parts = [`K = ${vector(c.K)}`];
      if (c.Nr !== null) parts.push(`Nr = ${fmt(c.Nr, 6)}`);
      if (c.L !== null) parts.push(`L = ${matrix(c.L)}`);
      if (c.observer_poles !== null) parts.push(`observer poles ${poleList(c.observer_poles).join(", ")}`);
      return { kind: `state feedback ${form}, x̂ ${estimate}`, law: parts.join(", ") };
    }
    case "pid": {
      const weights = c.b !== 1 || c.c !== 1 ? `, b = ${fmt(c.b, 6)}, c = ${fmt(c.c, 6)}` : "";
      return { kind: "PID on e = r − y", law: `Kp = ${fmt(c.Kp, 6)}, Ki = ${fmt(c.Ki, 6)}, Kd = ${fmt(c.Kd, 6)}, N = ${fmt(c.N, 6)}${c.Tt === null ? "" : `, Tt = ${fmt(c.Tt, 6)} s`}${weights}` };
    }
    case "lti": {
      const time = c.dt === null ? "continuous (Tustin at the run's sample time)" : `discrete, dt = ${fmt(c.dt * 1000)} ms`;
      const law = c.num && c.den ? `num = ${vector(c.num)}, den = ${vector(c.den)}` : `A = ${matrix(c.A ?? [])}, B = ${matrix(c.B ?? [])}, C = ${matrix(c.C ?? [])}, D = ${matrix(c.D ?? [])}`;
      const ff = c.ff_num && c.ff_den ? `; feed-forward ff_num = ${vector(c.ff_num)}, ff_den = ${vector(c.ff_den)}` : "";
      const own = c.B_r || c.D_r ? `; reference input B_r = ${matrix(c.B_r ?? [])}, D_r = ${matrix(c.D_r ?? [])}` : "";
      return { kind: `LTI controller on e = r − y, ${time}`, law: law + ff + own };
    }
    case "open_loop":
      return { kind: "open loop", law: "u = r" };
    case "predefined":
      return { kind: "the plant's predefined controller", law: "" };
  }
}

/** −83.49 − 179.2j; a real pole without its imaginary part. */
export function complexText(p: Complex): string {
  return p.im ? `${fmt(p.re)} ${p.im < 0 ? "−" : "+"} ${fmt(Math.abs(p.im))}j` : fmt(p.re);
}

/** The poles as a list, each conjugate pair once as a ± bj. */
export function poleList(poles: Complex[]): string[] {
  const used = new Set<number>();
  const out: string[] = [];
  poles.forEach((p, i) => {
    if (used.has(i)) return;
    used.add(i);
    const tol = 1e-9 * Math.max(1, Math.hypot(p.re, p.im));
    const twin = p.im ? poles.findIndex((q, j) => !used.has(j) && Math.abs(q.re - p.re) <= tol && Math.abs(q.im + p.im) <= tol) : -1;
    if (twin >= 0) used.add(twin);
    out.push(twin >= 0 ? `${fmt(p.re)} ± ${fmt(Math.abs(p.im))}j` : complexText(p));
  });
  return out;
}

/** A controller file's format as people say it: "Python (py)", "toml". */
export function formatText(format: string): string {
  return format === "py" ? "Python (py)" : format;
}

/** Stable or not, and what that means in the report's domain (for a Python controller,
 * checked by trial runs: whether they ran through). */
export function verdictText(r: Pick<ControllerReportOut, "stable" | "domain">): string {
  if (r.domain === "trial") return r.stable ? "ran through: the trial runs stayed bounded, without an error" : "failed: a trial run raised an error, was too slow or diverged (the problems below say which)";
  if (r.domain === "z") return r.stable ? "stable: every closed-loop pole lies inside the unit circle" : "unstable: a closed-loop pole lies on or outside the unit circle";
  return r.stable ? "stable: every closed-loop pole has a negative real part" : "unstable: a closed-loop pole has a non-negative real part";
}

/** Gain and phase margin; a missing margin (no crossover) is infinite. */
export function marginText(r: Pick<ControllerReportOut, "gain_margin_db" | "phase_margin_deg">): { gain: string; phase: string } {
  return {
    gain: r.gain_margin_db === null ? "∞" : `${fmt(r.gain_margin_db, 3)} dB`,
    phase: r.phase_margin_deg === null ? "∞" : `${fmt(r.phase_margin_deg, 3)}°`,
  };
}

/** "30°", "500 mm": an amount in the unit people read (SI in, display out). */
export function amountText(value: number, siUnit: string): string {
  const d = display(siUnit);
  const v = fmt(value * d.scale);
  return d.unit === "°" ? `${v}°` : d.unit ? `${v} ${d.unit}` : v;
}

/** The peak |u| for the report's step against the actuator limit; `over`: it saturates.
 * An unstable loop has none (the report's null): u grows without bound. */
export function peakText(r: Pick<ControllerReportOut, "peak_u" | "u_max" | "step_amplitude">, referenceUnit: string, inputUnit = "V"): { text: string; over: boolean } {
  const step = `for a step of ${amountText(r.step_amplitude, referenceUnit)}`;
  if (r.peak_u === null) return { text: `none ${step}: the loop is unstable, u grows until it saturates at ±${fmt(r.u_max)} ${inputUnit}`, over: true };
  const over = Math.abs(r.peak_u) > r.u_max;
  return { text: `${fmt(Math.abs(r.peak_u))} ${inputUnit} ${over ? "beyond" : "within"} ±${fmt(r.u_max)} ${inputUnit} ${step}`, over };
}

/** Stable or not in a word or two (a badge): for a Python controller, its trial's outcome. */
export function verdictWord(r: Pick<ControllerReportOut, "stable" | "domain">): string {
  if (r.domain === "trial") return r.stable ? "ran through" : "failed";
  return r.stable ? "stable" : "unstable";
}

/** Late answers none of which the controller's own compute time made: not counted
 * against it (the same words as the server's report). */
export const LATE_NOT_SLOW = ", none of them slow in the controller itself: the machine was busy (a simulation waits for them; on the rig each would hold the last u)";

/** µs to the 3 significant digits that matter at that scale: 41.23 → "41.2". */
const us = (x: number) => fmt(x, 3);

/** "Compute time per step: median 41.2 µs, p99 88.1 µs (max 310 µs); round trip median
 * 120 µs; 0 late of 4000 steps": a Python controller's time in its sandbox, and the round
 * trip the run waits for. */
export function computeText(c: ComputeTimes): string {
  return (
    `Compute time per step: median ${us(c.median_us)} µs, p99 ${us(c.p99_us)} µs (max ${us(c.max_us)} µs); ` +
    `round trip median ${us(c.round_trip_median_us)} µs, p99 ${us(c.round_trip_p99_us)} µs; ` +
    `${c.misses.toLocaleString("en")} late of ${c.steps.toLocaleString("en")} steps` +
    (c.slow ? `, ${c.slow.toLocaleString("en")} of them slower than the deadline in the controller itself` : c.misses ? LATE_NOT_SLOW : "")
  );
}
