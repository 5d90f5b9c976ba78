// A run's own page (shareable): anyone who opens it follows the run live, its parameter
// changes arriving as they are made; an ended run replays from its recording.
import { api } from "../api";
import { h, link } from "../dom";
import type { ChangeEntry } from "../paramlog";
import type { PlantDetail, RunInfo } from "../protocol.gen";
import { RunPanel } from "../runpanel";
import { runSettings } from "../settings";
import { EXPERIMENTS, failure, loading, pageHeader, plantDetail } from "./common";

export async function runPage(root: HTMLElement, params: Record<string, string>): Promise<() => void> {
  root.append(loading());
  let run: RunInfo;
  let plant: PlantDetail;
  try {
    run = await api.run(params.id);
    plant = await plantDetail(run.plant);
  } catch (err) {
    root.replaceChildren(failure(err));
    return () => undefined;
  }
  const rows = h("tbody");
  const none = h("p.muted", "No live parameter changes (yet).");
  const table = h("table.changes", { "data-testid": "param-changes", hidden: true }, h("thead", h("tr", h("th", "t (s)"), h("th", "sample k"), h("th", "what changed"))), rows);
  const addRow = (c: ChangeEntry) => {
    rows.append(h("tr", { "data-k": c.k }, h("td", c.t.toFixed(3)), h("td", c.k), h("td", c.text)));
    table.hidden = false;
    none.hidden = true;
  };
  const panel = new RunPanel(run, plant, { onChange: addRow }); // the recorded ones first
  root.replaceChildren(
    pageHeader(`Run ${run.id}`, [[`/plants/${plant.id}`, plant.name], [`/plants/${plant.id}/${run.experiment}`, EXPERIMENTS[run.experiment]?.title ?? run.experiment]], h("p.lead", `${plant.name} · ${run.experiment} · ${run.mode} · started ${new Date(run.created_at * 1000).toLocaleString()}`)),
    panel.root,
    h("section.panel", h("h2", "Parameter changes"), h("p.hint", "Each change holds from its sample on; the plot marks it with a dotted line."), none, table),
    h("section.panel", h("h2", "Settings"), settingsTable(run, plant), h("details.source", h("summary", "As sent (JSON, SI units)"), h("pre.request", JSON.stringify(run.request, null, 2)))),
    h("p", link(`/plants/${plant.id}/${run.experiment}`, `Start your own ${EXPERIMENTS[run.experiment]?.title.toLowerCase() ?? "run"}`)),
  );
  return () => panel.destroy();
}

function settingsTable(run: RunInfo, plant: PlantDetail): HTMLElement {
  return h(
    "table.settings",
    { "data-testid": "run-settings" },
    ...runSettings(run, plant).map((s) => h("tbody", h("tr", h("th", { colspan: 2, scope: "colgroup" }, s.title)), ...s.rows.map(([k, v]) => h("tr", h("td", k), h("td", v))))),
  );
}
