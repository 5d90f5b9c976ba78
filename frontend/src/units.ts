// SI inside, degrees at the edge: how a channel or field is shown to the user.

export interface Display {
  unit: string;
  /** displayed = scale · SI value */
  scale: number;
}

const DISPLAY: Record<string, Display> = {
  rad: { unit: "°", scale: 180 / Math.PI },
  "rad/s": { unit: "°/s", scale: 180 / Math.PI },
  m: { unit: "mm", scale: 1000 },
  "m/s": { unit: "mm/s", scale: 1000 },
};

export function display(siUnit: string): Display {
  return DISPLAY[siUnit] ?? { unit: siUnit, scale: 1 };
}

/** A number for people: 4 significant digits, no exponent for ordinary magnitudes. */
export function fmt(x: number | null | undefined, digits = 4): string {
  if (x === null || x === undefined || !Number.isFinite(x)) return "—";
  if (x === 0) return "0";
  const a = Math.abs(x);
  if (a >= 1e-3 && a < 1e6) return String(Number(x.toPrecision(digits)));
  return x.toExponential(digits - 1);
}

/** An SI value as the page shows it: "30°", "0.5 m" → "500 mm", "1.2 V". */
export function quantity(x: number | null | undefined, siUnit: string, digits = 4): string {
  const d = display(siUnit);
  const v = x === null || x === undefined ? x : x * d.scale;
  return d.unit === "°" ? `${fmt(v, digits)}°` : d.unit ? `${fmt(v, digits)} ${d.unit}` : fmt(v, digits);
}
