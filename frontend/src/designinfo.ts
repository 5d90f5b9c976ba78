// A designed loop in words and chart series, without DOM: the verdict said plainly, the
// peak input against the actuator limit, the margins, the gain as printed, the root locus.
import type { Complex, LoopOut, MarginsOut, RootLocusOut } from "./protocol.gen";
import { fmt } from "./units";

/** A series for plot.ts's chart (the same shape; no plotly here). */
export interface LocusSeries {
  /** NaN where a line breaks (with y null) */
  x: number[];
  y: (number | null)[];
  name: string;
  mode: "lines" | "markers";
  dash?: "dot";
}

/** "stable" or "unstable", said plainly, with the reason the server gave. */
export function verdictText(loop: Pick<LoopOut, "verdict" | "reason">): { text: string; stable: boolean } {
  const stable = loop.verdict === "asymptotically stable";
  if (stable) return { text: `Closed loop: stable (${loop.reason}).`, stable };
  if (loop.verdict === "marginally stable") return { text: `Closed loop: NOT asymptotically stable — ${loop.reason}: it does not settle.`, stable };
  return { text: `Closed loop: UNSTABLE — ${loop.reason}. A run with this controller diverges.`, stable };
}

/** The peak input a reference step asks for, against the limit; `step` is the step as the
 * page shows it ("30°"). A warning when it passes the limit or the loop is unstable. */
export function peakText(loop: Pick<LoopOut, "peak_u" | "u_max" | "saturates">, step: string): { text: string; warn: boolean } {
  if (loop.peak_u === null) return { text: `Predicted peak input: none (the loop is not stable, u grows without bound); the actuator gives ±${fmt(loop.u_max)} V.`, warn: true };
  const head = `Predicted peak input for a step of r by ${step}: |u| = ${fmt(loop.peak_u, 3)} V`;
  if (loop.saturates) return { text: `${head}, beyond the actuator's ±${fmt(loop.u_max)} V: the input saturates, and a run will not follow the linear prediction. Lower the gains or the reference.`, warn: true };
  return { text: `${head}, within the actuator's ±${fmt(loop.u_max)} V.`, warn: false };
}

/** Rows of the margins table: value and where (rad/s); "none" where no crossover. */
export function marginRows(m: MarginsOut): [string, string][] {
  const at = (w: number | null) => (w === null ? "" : ` at ω = ${fmt(w)} rad/s`);
  const gm = m.gain_margin_db === null ? "∞ (no phase crossover)" : `${fmt(m.gain_margin_db, 3)} dB${at(m.phase_crossover)}`;
  const pm = m.phase_margin_deg === null ? "∞ (no gain crossover)" : `${fmt(m.phase_margin_deg, 3)}°${at(m.gain_crossover)}`;
  return [
    ["gain margin", gm],
    ["phase margin", pm],
  ];
}

/** "K = [20, -93.56, 3.362, 0.9623]" (ASCII minus: the numbers paste into any field) */
export function gainText(K: number[], digits = 6): string {
  return `K = [${K.map((k) => fmt(k, digits)).join(", ")}]`;
}

/** "−3.2 ± 4.1j" */
export function complexText(z: Complex): string {
  const re = fmt(z.re).replace(/^-/, "−");
  return Math.abs(z.im) > 1e-12 * Math.max(1, Math.abs(z.re)) ? `${re} ${z.im < 0 ? "−" : "+"} ${fmt(Math.abs(z.im))}j` : re;
}

/** The root locus as chart series: every branch in one line (gaps between branches), the
 * open loop's poles and the zeros in view, the design's poles (k = 1), and in z the unit
 * circle. */
export function locusSeries(rl: RootLocusOut, design: Complex[]): LocusSeries[] {
  // branches leave for infinity as k grows: points far outside the window of the poles,
  // zeros and design are left out, so the chart's own scaling shows what matters
  const win = locusWindow(rl, design);
  const inside = (re: number, im: number) => re >= win.x[0] && re <= win.x[1] && im >= win.y[0] && im <= win.y[1];
  const x: number[] = [];
  const y: (number | null)[] = [];
  rl.re.forEach((row, i) => {
    row.forEach((re, j) => {
      const im = rl.im[i][j];
      const ok = re !== null && im !== null && inside(re, im);
      x.push(ok ? re : NaN);
      y.push(ok ? im : null);
    });
    x.push(NaN);
    y.push(null);
  });
  const hi = rl.gains[rl.gains.length - 1] ?? 0;
  const out: LocusSeries[] = [{ x, y, name: `closed-loop poles, loop gain k from 0 to ${fmt(hi)}`, mode: "lines" }];
  out.push({ x: rl.poles.map((p) => p.re), y: rl.poles.map((p) => p.im), name: "open loop's poles (k = 0)", mode: "markers" });
  const zeros = rl.zeros.filter((p) => inside(p.re, p.im));
  if (zeros.length) out.push({ x: zeros.map((p) => p.re), y: zeros.map((p) => p.im), name: "zeros (where branches end)", mode: "markers" });
  out.push({ x: design.map((p) => p.re), y: design.map((p) => p.im), name: "the design's poles (k = 1)", mode: "markers" });
  if (rl.domain === "z") {
    const n = 181;
    const angles = Array.from({ length: n }, (_, i) => (2 * Math.PI * i) / (n - 1));
    out.push({ x: angles.map(Math.cos), y: angles.map(Math.sin), name: "unit circle |z| = 1", mode: "lines", dash: "dot" });
  }
  return out;
}

/** A window around the interesting part of the locus: the open loop's poles and the
 * design's (in z with the unit circle), generously padded. */
export function locusWindow(rl: RootLocusOut, design: Complex[]): { x: [number, number]; y: [number, number] } {
  const pts = [...rl.poles, ...design]; // zeros far away would flatten the rest: not these
  if (rl.domain === "z") pts.push({ re: 1, im: 1 }, { re: -1, im: -1 });
  const xs = pts.map((p) => p.re);
  const ys = pts.map((p) => p.im);
  const pad = (lo: number, hi: number): [number, number] => {
    const span = Math.max(hi - lo, 1e-9, 0.1 * Math.max(Math.abs(lo), Math.abs(hi)));
    return [lo - span, hi + span];
  };
  return { x: pad(Math.min(...xs), Math.max(...xs)), y: pad(Math.min(...ys, 0), Math.max(...ys, 0)) };
}
