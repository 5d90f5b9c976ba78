// The gate: every plant × experiment as a card, and the recent runs.
import { api } from "../api";
import { fill, h, link } from "../dom";
import type { RunSummaryInfo } from "../protocol.gen";
import { fmt } from "../units";
import { EXPERIMENTS, failure, loading } from "./common";

export async function home(root: HTMLElement): Promise<void> {
  const cards = h("div.cards", loading());
  const recent = h("div", loading());
  root.append(
    h("header.page.hero", h("h1", "E-Lab"), h("p.lead", "A web laboratory for control engineering. Pick a plant and an experiment; the response draws itself live as the run goes.")),
    h("section", { "aria-labelledby": "plants-h" }, h("h2#plants-h", "Plants and experiments"), cards),
    h("section", { "aria-labelledby": "runs-h" }, h("h2#runs-h", "Recent runs"), recent),
  );
  try {
    const plants = await api.plants();
    fill(
      cards,
      ...plants.map((p) =>
        h(
          "article.card",
          { "data-plant": p.id },
          h("h3", link(`/plants/${p.id}`, p.name)),
          h("p", p.summary),
          h("p.modes", p.modes.map((m) => (m === "rig" ? "real rig" : m)).join(" · ")),
          h("ul.experiments", ...p.experiments.map((e) => h("li", link(`/plants/${p.id}/${e}`, EXPERIMENTS[e]?.title ?? e), h("small", EXPERIMENTS[e]?.blurb ?? "")))),
        ),
      ),
    );
  } catch (err) {
    fill(cards, failure(err));
  }
  try {
    const list = await api.runs({ limit: 10 });
    fill(recent, list.runs.length ? runTable(list.runs) : h("p.muted", "No runs yet: start one from an experiment above."), list.total > list.runs.length ? h("p", link("/runs", `All ${list.total} runs`)) : null);
  } catch (err) {
    fill(recent, failure(err));
  }
}

export function runTable(runs: RunSummaryInfo[]): HTMLElement {
  return h(
    "table.runs",
    h("thead", h("tr", h("th", "Run"), h("th", "Plant"), h("th", "Experiment"), h("th", "Status"), h("th", "Length"), h("th", "Started"))),
    h(
      "tbody",
      ...runs.map((r) =>
        h(
          "tr",
          h("td", link(`/runs/${r.id}`, h("span.mono", r.id))),
          h("td", r.plant),
          h("td", r.experiment),
          h("td", h("span.badge", { "data-state": r.status }, r.status)),
          h("td", `${fmt(r.n_samples * r.Ts)} s`),
          h("td", new Date(r.created_at * 1000).toLocaleString()),
        ),
      ),
    ),
  );
}
