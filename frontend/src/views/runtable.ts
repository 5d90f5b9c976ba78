// Runs as a table (the start page's recent runs, the runs page): whose each one is, and
// Stop or Delete for those the viewer may control.
import { ENDED } from "../access";
import { api } from "../api";
import { h, link } from "../dom";
import { outcomeChip } from "../outcome";
import type { RunSummaryInfo } from "../protocol.gen";
import { fmt } from "../units";
import { errorText, EXPERIMENTS } from "./common";

export interface RowActions {
  /** a run was stopped or deleted: show the list again */
  changed(): void;
  failed(message: string): void;
  /** the runs ticked to compare (a column of checkboxes when given); `picked` is called
   * after each tick */
  compare?: { chosen: Set<string>; picked(): void };
}

/** The table in a box that scrolls sideways on a narrow screen (the page itself never does).
 * `plants`: the plants' names by id (a plant not in it shows its id). */
export function runTable(runs: RunSummaryInfo[], actions?: RowActions, plants: Record<string, string> = {}): HTMLElement {
  return h("div.table-scroll", table(runs, actions, plants));
}

function table(runs: RunSummaryInfo[], actions: RowActions | undefined, plants: Record<string, string>): HTMLElement {
  return h(
    "table.runs",
    h("thead", h("tr", actions?.compare ? h("th", h("span.visually-hidden", "Compare")) : null, h("th", "Run"), h("th", "Plant"), h("th", "Experiment"), h("th", "Owner"), h("th", "Status"), h("th", "Length"), h("th", "Started"), actions ? h("th", h("span.visually-hidden", "Actions")) : null)),
    h(
      "tbody",
      ...runs.map((r) =>
        h(
          "tr",
          { "data-run": r.id },
          actions?.compare ? h("td", compareBox(r, actions.compare)) : null,
          h("td", link(`/runs/${r.id}`, h("span.mono", r.id))),
          h("td", { "data-plant": r.plant }, plants[r.plant] ?? r.plant),
          h("td", { "data-experiment": r.experiment }, EXPERIMENTS[r.experiment]?.title ?? r.experiment),
          h("td.owner", r.mine ? h("span", { title: r.owner }, "you") : r.owner, r.private ? h("span.badge.private", { title: "only its owner and instructors may see it" }, "private") : null),
          h("td", h("span.badge", { "data-state": r.status }, r.status), " ", outcomeChip(r.outcome)),
          h("td", `${fmt(r.n_samples * r.Ts)} s`),
          h("td", new Date(r.created_at * 1000).toLocaleString()),
          actions ? h("td.actions-cell", rowAction(r, actions)) : null,
        ),
      ),
    ),
  );
}

/** A run's tick for comparing. */
function compareBox(r: RunSummaryInfo, compare: NonNullable<RowActions["compare"]>): HTMLInputElement {
  return h("input", {
    type: "checkbox",
    "aria-label": `compare run ${r.id}`,
    checked: compare.chosen.has(r.id),
    onchange: (ev: Event) => {
      const box = ev.target as HTMLInputElement;
      if (box.checked) compare.chosen.add(r.id);
      else compare.chosen.delete(r.id);
      compare.picked();
    },
  });
}

/** Stop for a live run, Delete for an ended one; nothing for runs the viewer may not control. */
function rowAction(r: RunSummaryInfo, actions: RowActions): HTMLButtonElement | null {
  if (!r.can_control) return null;
  const act = async (button: HTMLButtonElement, action: () => Promise<unknown>) => {
    button.disabled = true;
    try {
      await action();
    } catch (err) {
      actions.failed(`${r.id}: ${errorText(err)}`);
    }
    actions.changed();
  };
  if (!ENDED.has(r.status)) {
    const stop = h("button", { type: "button", "aria-label": `Stop run ${r.id}`, onclick: () => void act(stop, () => api.stop(r.id)) }, "Stop");
    return stop;
  }
  const del = h(
    "button.danger",
    {
      type: "button",
      "aria-label": `Delete run ${r.id}`,
      onclick: () => {
        if (confirm(`Delete run ${r.id} and its recording? This cannot be undone.`)) void act(del, () => api.deleteRun(r.id));
      },
    },
    "Delete",
  );
  return del;
}
