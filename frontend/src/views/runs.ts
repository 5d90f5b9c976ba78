// Every run the viewer may see, newest first: all, only mine, or only the live ones (in
// the address: ?owner=me, ?live=true), by plant; page through; statuses refresh by
// themselves.
import { filterFrom, filterQuery, type RunsFilter } from "../access";
import { api, queryString } from "../api";
import { fill, h } from "../dom";
import { failure, pageHeader } from "./common";
import { runTable } from "./runtable";

const PAGE = 25;
const REFRESH_MS = 3000;
const FILTERS: [RunsFilter, string][] = [
  ["all", "All runs"],
  ["mine", "My runs"],
  ["live", "Live now"],
];
const EMPTY: Record<RunsFilter, string> = { all: "No runs.", mine: "You have no runs yet: start one from an experiment.", live: "No run is live right now." };

export async function runsPage(root: HTMLElement, _params: Record<string, string>, query: URLSearchParams): Promise<() => void> {
  const plants = await api.plants().catch(() => []);
  const plant = h("select", { id: "plant-filter", "aria-label": "plant" }, h("option", { value: "" }, "all plants"), ...plants.map((p) => h("option", { value: p.id }, p.name)));
  plant.value = query.get("plant") ?? "";
  const names = Object.fromEntries(plants.map((p) => [p.id, p.name]));
  let filter = filterFrom(query);
  let offset = Math.max(0, Number(query.get("offset")) || 0);
  const radios = FILTERS.map(([value, label]) => {
    const input = h("input", { type: "radio", name: "show", value, checked: value === filter, onchange: () => ((filter = value), go(0)) });
    return h("label.inline", input, ` ${label}`);
  });
  const chosen = new Set<string>();
  const compareLink = h("a.button", { "data-testid": "compare-link", "aria-disabled": "true" }, "Compare the two ticked");
  const picked = () => {
    const ids = [...chosen];
    const ready = ids.length === 2;
    compareLink.setAttribute("aria-disabled", String(!ready));
    if (ready) {
      compareLink.setAttribute("href", `/compare?runs=${ids.join(",")}`);
      compareLink.setAttribute("data-link", "");
    } else compareLink.removeAttribute("href");
    fill(compareLink, ready ? "Compare the two ticked" : `Tick two runs to compare (${ids.length} ticked)`);
  };
  picked();
  const table = h("div");
  const pager = h("div.toolbar");
  const msg = h("p.error", { role: "alert", "data-testid": "runs-error" });
  root.append(
    pageHeader("Runs", [["/runs", "Runs"]], h("p.lead", "Every run on this lab you may see, newest first. Open one to follow it live or replay it.")),
    h("div.toolbar", h("div.group", { role: "radiogroup", "aria-label": "which runs" }, ...radios), h("label.inline", "Plant ", plant), compareLink),
    msg,
    table,
    pager,
  );

  const load = async () => {
    try {
      const list = await api.runs({ plant: plant.value || undefined, ...filterQuery(filter), limit: PAGE, offset });
      const actions = { changed: () => void load(), failed: (m: string) => fill(msg, m), compare: { chosen, picked } };
      fill(table, list.runs.length ? runTable(list.runs, actions, names) : h("p.muted", EMPTY[filter]));
      const prev = h("button", { type: "button", disabled: offset === 0, onclick: () => go(Math.max(0, offset - PAGE)) }, "Newer");
      const next = h("button", { type: "button", disabled: offset + PAGE >= list.total, onclick: () => go(offset + PAGE) }, "Older");
      fill(pager, prev, `${list.total ? offset + 1 : 0}–${Math.min(offset + PAGE, list.total)} of ${list.total}`, next);
    } catch (err) {
      fill(table, failure(err));
    }
  };
  const go = (to: number) => {
    offset = to;
    fill(msg);
    history.replaceState(null, "", `/runs${queryString({ plant: plant.value || undefined, ...filterQuery(filter), offset: offset || undefined })}`);
    void load();
  };
  plant.addEventListener("change", () => go(0));
  await load();
  const timer = setInterval(() => void load(), REFRESH_MS);
  return () => clearInterval(timer);
}
