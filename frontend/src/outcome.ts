// How a run went beyond its state (the server's `outcome`: marks for what "finished"
// alone would hide): short words for a table, the server's sentences for a run's page.
import { h } from "./dom";
import type { OutcomeMark } from "./protocol.gen";

const SHORT: Record<OutcomeMark["kind"], string> = {
  left_range: "left its range",
  saturated: "saturated",
  beyond_actuator: "beyond the actuator",
  ran_away: "ran away",
};

/** "saturated, ran away" (empty: nothing to say or not known yet). */
export function outcomeWords(marks: OutcomeMark[] | null | undefined): string {
  return (marks ?? []).map((m) => SHORT[m.kind]).join(", ");
}

/** A chip for a runs table, its title the server's sentences; null when nothing to say. */
export function outcomeChip(marks: OutcomeMark[] | null | undefined): HTMLElement | null {
  if (!marks?.length) return null;
  return h("span.badge.outcome", { title: marks.map((m) => m.text).join("\n"), "data-testid": "outcome-chip" }, `⚠ ${outcomeWords(marks)}`);
}

/** The marks as a list for a run's page, each the server's sentence. */
export function outcomeItems(marks: OutcomeMark[]): HTMLElement[] {
  return marks.map((m) => h("li", { "data-kind": m.kind }, h("strong", `${SHORT[m.kind]}: `), m.text));
}
