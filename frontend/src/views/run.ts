// A run's own page (shareable): anyone who opens it follows the run live; an ended run
// replays from its recording.
import { api } from "../api";
import { h, link } from "../dom";
import type { PlantDetail, RunInfo } from "../protocol.gen";
import { RunPanel } from "../runpanel";
import { fmt } from "../units";
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
  const panel = new RunPanel(run, plant);
  const changes = run.param_changes.length
    ? h("table", h("thead", h("tr", h("th", "sample k"), h("th", "t (s)"), h("th", "new parameters"))), h("tbody", ...run.param_changes.map((c) => h("tr", h("td", c.k), h("td", fmt(c.t)), h("td.mono", JSON.stringify(c.params))))))
    : h("p.muted", "No live parameter changes (yet).");
  root.replaceChildren(
    pageHeader(`Run ${run.id}`, [[`/plants/${plant.id}`, plant.name], [`/plants/${plant.id}/${run.experiment}`, EXPERIMENTS[run.experiment]?.title ?? run.experiment]], h("p.lead", `${plant.name} · ${run.experiment} · ${run.mode} · started ${new Date(run.created_at * 1000).toLocaleString()}`)),
    panel.root,
    h("section.panel", h("h2", "Settings"), h("pre.request", JSON.stringify(run.request, null, 2))),
    h("section.panel", h("h2", "Parameter changes"), changes),
    h("p", link(`/plants/${plant.id}/${run.experiment}`, `Start your own ${EXPERIMENTS[run.experiment]?.title.toLowerCase() ?? "run"}`)),
  );
  return () => panel.destroy();
}
