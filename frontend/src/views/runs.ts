// Every run, newest first: filter by plant, page through, statuses refresh by themselves.
import { api } from "../api";
import { fill, h } from "../dom";
import { failure, pageHeader } from "./common";
import { runTable } from "./home";

const PAGE = 25;
const REFRESH_MS = 3000;

export async function runsPage(root: HTMLElement, _params: Record<string, string>, query: URLSearchParams): Promise<() => void> {
  const plants = await api.plants().catch(() => []);
  const plant = h("select", { id: "plant-filter", "aria-label": "plant" }, h("option", { value: "" }, "all plants"), ...plants.map((p) => h("option", { value: p.id }, p.name)));
  plant.value = query.get("plant") ?? "";
  let offset = Math.max(0, Number(query.get("offset")) || 0);
  const table = h("div");
  const pager = h("div.toolbar");
  root.append(pageHeader("Runs", [["/runs", "Runs"]], h("p.lead", "Every run on this lab, newest first. Open one to follow it live or replay it.")), h("div.toolbar", h("label.inline", "Plant ", plant)), table, pager);

  const load = async () => {
    try {
      const list = await api.runs({ plant: plant.value || undefined, limit: PAGE, offset });
      fill(table, list.runs.length ? runTable(list.runs) : h("p.muted", "No runs."));
      const prev = h("button", { type: "button", disabled: offset === 0, onclick: () => go(Math.max(0, offset - PAGE)) }, "Newer");
      const next = h("button", { type: "button", disabled: offset + PAGE >= list.total, onclick: () => go(offset + PAGE) }, "Older");
      fill(pager, prev, `${list.total ? offset + 1 : 0}–${Math.min(offset + PAGE, list.total)} of ${list.total}`, next);
    } catch (err) {
      fill(table, failure(err));
    }
  };
  const go = (to: number) => {
    offset = to;
    const q = new URLSearchParams();
    if (plant.value) q.set("plant", plant.value);
    if (offset) q.set("offset", String(offset));
    history.replaceState(null, "", `/runs${q.size ? "?" + q.toString() : ""}`);
    void load();
  };
  plant.addEventListener("change", () => go(0));
  await load();
  const timer = setInterval(() => void load(), REFRESH_MS);
  return () => clearInterval(timer);
}
