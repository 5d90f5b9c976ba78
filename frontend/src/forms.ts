// Form fields validated as the user types: a number with its unit and allowed range,
// the error shown under the field, and server field errors routed to the same place.

export interface NumberSpec {
  /** the API field path this input fills, e.g. "controller.K.0" or "signal.amplitude" */
  field: string;
  label: string;
  unit?: string;
  value: number;
  min?: number;
  max?: number;
  /** strict bounds: the value may not equal min / max */
  minExclusive?: boolean;
  maxExclusive?: boolean;
  integer?: boolean;
  step?: number | "any";
  hint?: string;
  /** element id prefix (default "f"), for pages with two forms over the same fields */
  idPrefix?: string;
}

export type Parsed = { ok: true; value: number } | { ok: false; message: string };

/** A bound as people read it: 3600, -1e6, 1e12. */
function bound(x: number): string {
  return Math.abs(x) >= 1e5 ? x.toExponential().replace("e+", "e") : String(x);
}

/** The allowed range in words, e.g. "> 0 and ≤ 3600". */
export function rangeText(spec: Pick<NumberSpec, "min" | "max" | "minExclusive" | "maxExclusive" | "integer">): string {
  const parts: string[] = [];
  if (spec.min !== undefined) parts.push(`${spec.minExclusive ? ">" : "≥"} ${bound(spec.min)}`);
  if (spec.max !== undefined) parts.push(`${spec.maxExclusive ? "<" : "≤"} ${bound(spec.max)}`);
  const kind = spec.integer ? "a whole number" : "a number";
  return parts.length ? `${kind} ${parts.join(" and ")}` : kind;
}

/** A decimal number as people write it: 16, -0.5, .5, 1e-3 (not 0x10, 1_000, Infinity). */
const DECIMAL = /^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/;

/** Parse what the user typed against the spec; the message names value and allowed range. */
export function parseNumber(text: string, spec: NumberSpec): Parsed {
  const t = text.trim();
  const allowed = rangeText(spec);
  if (t === "") return { ok: false, message: `${spec.label} is required: ${allowed}` };
  const ascii = t.replace(/^\u2212/, "-"); // the minus sign − as the page prints it
  const v = DECIMAL.test(ascii) ? Number(ascii) : NaN;
  if (!Number.isFinite(v)) {
    const hint = /^\d+,\d+$/.test(t) ? ` (write ${t.replace(",", ".")} with a decimal point)` : /^[+-]?0[xob]/i.test(t) ? " (write it in decimal digits)" : "";
    return { ok: false, message: `${spec.label}: "${t}" is not ${allowed}${hint}` };
  }
  if (spec.integer && !Number.isInteger(v)) return { ok: false, message: `${spec.label}: ${t} is not ${allowed}` };
  const low = spec.min !== undefined && (spec.minExclusive ? v <= spec.min : v < spec.min);
  const high = spec.max !== undefined && (spec.maxExclusive ? v >= spec.max : v > spec.max);
  if (low || high) return { ok: false, message: `${spec.label}: ${t} is out of range; allowed: ${allowed}` };
  return { ok: true, value: v };
}

/** Names of discriminated-union tags that pydantic puts into error locations. */
const TAGS = new Set(["predefined", "state_feedback", "pid", "lti", "open_loop", "step", "square", "sine", "chirp", "prbs", "samples"]);

/** "controller.state_feedback.K.2" → "controller.K.2" (the form's own field path). */
export function normaliseField(field: string): string {
  return field
    .split(".")
    .filter((p) => !TAGS.has(p))
    .join(".");
}

export class NumberField {
  readonly root: HTMLElement;
  readonly input: HTMLInputElement;
  private readonly error: HTMLElement;

  constructor(
    readonly spec: NumberSpec,
    onChange?: () => void,
  ) {
    const id = `${spec.idPrefix ?? "f"}-${spec.field.replace(/[^a-zA-Z0-9_-]/g, "-")}`;
    this.root = document.createElement("div");
    this.root.className = "field";
    const label = document.createElement("label");
    label.htmlFor = id;
    label.textContent = spec.label;
    const row = document.createElement("div");
    row.className = "field-row";
    this.input = document.createElement("input");
    this.input.id = id;
    this.input.name = spec.field;
    this.input.type = "text";
    this.input.inputMode = "decimal";
    this.input.autocomplete = "off";
    this.input.value = String(spec.value);
    this.input.dataset.field = spec.field;
    row.append(this.input);
    if (spec.unit) {
      const unit = document.createElement("span");
      unit.className = "unit";
      unit.textContent = spec.unit;
      row.append(unit);
    }
    const hint = document.createElement("small");
    hint.className = "hint";
    hint.textContent = spec.hint ?? `allowed: ${rangeText(spec)}`;
    this.error = document.createElement("small");
    this.error.className = "error";
    this.error.id = `${id}-error`;
    this.error.setAttribute("role", "alert");
    this.input.setAttribute("aria-describedby", this.error.id);
    this.root.append(label, row, hint, this.error);
    this.input.addEventListener("input", () => {
      this.check();
      onChange?.();
    });
  }

  /** The value, or null with the message shown under the field. */
  check(): number | null {
    const parsed = parseNumber(this.input.value, this.spec);
    this.setError(parsed.ok ? null : parsed.message);
    return parsed.ok ? parsed.value : null;
  }

  get value(): number | null {
    const parsed = parseNumber(this.input.value, this.spec);
    return parsed.ok ? parsed.value : null;
  }

  set value(v: number) {
    this.input.value = String(v);
    this.setError(null);
  }

  /** A field that cannot change now (e.g. a run's duration while it runs) is disabled. */
  set disabled(off: boolean) {
    this.input.disabled = off;
    this.root.classList.toggle("fixed", off);
  }

  setError(message: string | null): void {
    this.error.textContent = message ?? "";
    this.root.classList.toggle("invalid", message !== null);
    this.input.setAttribute("aria-invalid", String(message !== null));
  }
}

/** A group of fields checked together; server errors go to the field they name. */
export class FieldSet {
  readonly fields = new Map<string, NumberField>();

  add(field: NumberField): NumberField {
    this.fields.set(field.spec.field, field);
    return field;
  }

  get(path: string): NumberField | undefined {
    return this.fields.get(path);
  }

  /** Every field's value, or null if any is invalid (each invalid field shows why). */
  values(): Map<string, number> | null {
    const out = new Map<string, number>();
    let ok = true;
    for (const [path, f] of this.fields) {
      const v = f.check();
      if (v === null) ok = false;
      else out.set(path, v);
    }
    return ok ? out : null;
  }

  /** Show server field errors next to their fields; returns those no field took. */
  showErrors(errors: Map<string, string>): Map<string, string> {
    const rest = new Map<string, string>();
    for (const [field, message] of errors) {
      const f = this.fields.get(normaliseField(field));
      if (f) f.setError(message);
      else rest.set(field, message);
    }
    return rest;
  }

  clearErrors(): void {
    for (const f of this.fields.values()) f.setError(null);
  }
}
