// A run's live parameter changes as people read them. The stream and the run's record say
// what a change set (the new controller and/or reference, whole); what it altered follows
// from the settings the run had just before: its request, then each earlier change. The
// difference is taken as the server's own answer to the change takes it
// (backend/elab/runs/changes.py) and said in words by changes.ts.
import { changedTo, describeChanges } from "./changes";
import type { ParamDiff, PlantDetail } from "./protocol.gen";

const PARTS = ["controller", "signal"] as const;
type Scalar = ParamDiff["before"];

/** A change as the run's record and the stream's `params` notice carry it. */
export interface ChangeLike {
  k: number;
  t: number;
  params: Record<string, unknown>;
}

export interface ChangeEntry {
  k: number;
  t: number;
  diffs: ParamDiff[];
  /** "K1 20 → 30 V/rad; reference amplitude 30 → 60°" */
  text: string;
  /** The mark's label on the plot, whole values only: "K1 → 30 V/rad, +1 more" */
  label: string;
  params: Record<string, unknown>;
}

function flat(path: string, value: unknown, out: Map<string, Scalar>): Map<string, Scalar> {
  if (Array.isArray(value)) value.forEach((v, i) => flat(`${path}.${i}`, v, out));
  else if (value !== null && typeof value === "object") for (const [key, v] of Object.entries(value)) flat(`${path}.${key}`, v, out);
  else out.set(path, value === undefined ? null : (value as Scalar));
  return out;
}

function same(a: Scalar, b: Scalar): boolean {
  if (typeof a === "number" && typeof b === "number") return a === b || Math.abs(a - b) <= 1e-12 * Math.max(Math.abs(a), Math.abs(b));
  return a === b;
}

/**
 * The values of `after` (JSON, SI) that differ from `before`, as `part.field.index` paths:
 * the fields of `after` first, then those only `before` had. Numbers equal to 12 significant
 * digits are equal (degrees typed in a form come back as radians a rounding away).
 */
export function diffParams(part: string, before: unknown, after: unknown): ParamDiff[] {
  const old = flat(part, before, new Map());
  const now = flat(part, after, new Map());
  const keys = [...now.keys(), ...[...old.keys()].filter((k) => !now.has(k))];
  return keys.filter((k) => !same(old.get(k) ?? null, now.get(k) ?? null)).map((field) => ({ field, before: old.get(field) ?? null, after: now.get(field) ?? null }));
}

/** The controller a run uses for a request's `controller`: "predefined" is the plant's own. */
function resolved(controller: unknown, plant: PlantDetail): unknown {
  const kind = (controller as { kind?: unknown } | null)?.kind;
  return kind === "predefined" ? plant.predefined : controller;
}

/**
 * A label for a change's mark on the plot, at most `max` characters of whole parts: as many
 * of `parts` as fit, then how many more there are (the table and the mark's hover have the
 * whole sentence). A number is never cut: a first part too long alone gives only its count.
 */
export function markLabel(parts: string[], max = 40): string {
  let label = "";
  let shown = 0;
  for (const part of parts) {
    const rest = parts.length - shown - 1;
    const next = label ? `${label}, ${part}` : part;
    if (next.length + (rest ? `, +${rest} more`.length : 0) > max) break;
    label = next;
    shown += 1;
  }
  if (shown === parts.length) return label;
  const more = parts.length - shown;
  return label ? `${label}, +${more} more` : `${more} change${more === 1 ? "" : "s"}`;
}

/** The run's changes in order of arrival, each with what it altered. */
export class ParamLog {
  readonly entries: ChangeEntry[] = [];
  private readonly now: Record<string, unknown>;

  constructor(
    request: Record<string, unknown>,
    private readonly plant: PlantDetail,
  ) {
    this.now = { controller: resolved(request.controller ?? { kind: "predefined" }, plant), signal: request.signal ?? plant.default_signal };
  }

  /** Add a change (the same change twice — from the record and the stream — is kept once);
   * the entry, or null when it was there already. */
  add(change: ChangeLike): ChangeEntry | null {
    const key = JSON.stringify(change.params);
    if (this.entries.some((e) => e.k === change.k && JSON.stringify(e.params) === key)) return null;
    const diffs: ParamDiff[] = [];
    for (const part of PARTS) {
      if (!(part in change.params)) continue;
      const next = part === "controller" ? resolved(change.params[part], this.plant) : change.params[part];
      diffs.push(...diffParams(part, this.now[part], next));
      this.now[part] = next;
    }
    const id = change.params.controller_id;
    const uploaded = typeof id === "string" ? `controller ${id}` : "";
    const text = [uploaded, describeChanges(diffs, this.plant)].filter(Boolean).join("; ") || "the same values again";
    const parts = [uploaded, ...changedTo(diffs, this.plant)].filter(Boolean);
    const label = parts.length ? markLabel(parts) : text;
    const entry = { k: change.k, t: change.t, diffs, text, label, params: change.params };
    this.entries.push(entry);
    return entry;
  }
}
