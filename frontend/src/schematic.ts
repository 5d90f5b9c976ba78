// The geometry of the plants' animated schematics: angles and positions (SI, as streamed)
// → coordinates. Pure functions, in the mathematician's frame (x right, y up, angles
// counter-clockwise); `toScreen` turns a point into SVG coordinates (y down).

export interface Pt {
  x: number;
  y: number;
}

export const DEG = 180 / Math.PI;

/** The point at `angle` (rad, counter-clockwise from +x) and distance `r` from the origin. */
export function polar(angle: number, r: number): Pt {
  return { x: r * Math.cos(angle), y: r * Math.sin(angle) };
}

/** A point relative to a centre (cx, cy) on the screen, where y grows downwards. */
export function toScreen(p: Pt, cx: number, cy: number): Pt {
  return { x: cx + p.x, y: cy - p.y };
}

/** An SVG path through the points (screen coordinates), two decimals. */
export function pathD(points: Pt[]): string {
  return points.map((p, i) => `${i ? "L" : "M"}${p.x.toFixed(2)} ${p.y.toFixed(2)}`).join("");
}

/**
 * The flexible link in the frame of the servo arm (x along the arm, from the hub): the
 * shape of a cantilever under a tip load, w(s) = d (3s² − s³)/2 with s the fraction of the
 * length, scaled so that the tip sits at distance `length` and at the deflection angle
 * `alpha` (rad) seen from the hub — the angle the link's strain gauge reports. `n + 1` points
 * from the hub to the tip; α = 0 is the straight link.
 */
export function linkShape(alpha: number, length: number, n = 12): Pt[] {
  const d = length * Math.tan(alpha);
  const scale = Math.cos(alpha); // the raw tip (L, d) lies at L / cos α
  const points: Pt[] = [];
  for (let i = 0; i <= n; i++) {
    const s = i / n;
    points.push({ x: s * length * scale, y: ((d * (3 * s * s - s * s * s)) / 2) * scale });
  }
  return points;
}

/** `points` turned by `angle` (rad, counter-clockwise) about the origin. */
export function rotate(points: Pt[], angle: number): Pt[] {
  const c = Math.cos(angle);
  const s = Math.sin(angle);
  return points.map((p) => ({ x: c * p.x - s * p.y, y: s * p.x + c * p.y }));
}

/**
 * The free end of a pendulum of `length` pivoted at the origin, at `beta` (rad) from
 * upright, positive towards +x (clockwise on the screen): β = 0 points up, β = π hangs down.
 * The double pendulum streams β₁ and β₂ this way, both absolute (β₂ near 180°).
 */
export function pendulumEnd(beta: number, length: number): Pt {
  return { x: length * Math.sin(beta), y: length * Math.cos(beta) };
}

/** The smallest of 1, 2, 5 × 10ⁿ that is at least `v` (a view's half-width, > 0). */
export function niceSpan(v: number): number {
  const a = Math.abs(v);
  if (!(a > 0) || !Number.isFinite(a)) return 1;
  const decade = 10 ** Math.floor(Math.log10(a));
  for (const m of [1, 2, 5, 10]) if (m * decade >= a * (1 - 1e-12)) return m * decade;
  return 10 * decade;
}

export interface BeltView {
  /** the load's centre and the reference's mark, px from the belt's centre (right +) */
  load: number;
  target: number;
  /** stroke-dashoffset of the belt's marks (px): the belt moves with the load */
  dash: number;
  /** the drums' rotation (degrees, clockwise on the screen as the belt moves right) */
  drum: number;
}

/**
 * The belt conveyor seen from the side, belt position `x` and reference `r` (m): the view
 * shows ±`span` m over ±`halfWidth` px; drums of `drumRadius` px turn with the belt.
 */
export function beltView(x: number, r: number, span: number, halfWidth: number, drumRadius: number): BeltView {
  const px = halfWidth / span;
  return { load: x * px, target: r * px, dash: -x * px, drum: ((x * px) / drumRadius) * DEG };
}

/** A view's half-width that only grows: `current` while |v| fits in it with 10 % to spare,
 * else the next 1-2-5 value that does (the load never leaves the belt, the view never
 * jitters). */
export function growSpan(current: number, v: number): number {
  const need = 1.1 * Math.abs(v);
  return need <= current ? current : niceSpan(need);
}

/** A channel's symbol from its label: "servo angle θ" → θ, "pendulum 1 angle β₁ from
 * upright" → β₁, "belt position x" → x. */
export function symbol(label: string): string | null {
  return /(?:^|\s)([A-Za-z\u0370-\u03ff][\u2080-\u2089]?)(?=\s|$)/u.exec(label)?.[1] ?? null;
}

/** A value for the readout: fixed decimals, so the digits do not jump as it changes. */
export function fixed(v: number): string {
  if (!Number.isFinite(v)) return "—";
  const text = v.toFixed(Math.abs(v) >= 100 ? 1 : 2);
  return Number(text) === 0 ? text.replace("-", "") : text;
}
