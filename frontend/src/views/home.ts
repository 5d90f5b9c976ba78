// The gate: the class demo (when an instructor pinned one), every plant × experiment as
// a card, and the recent runs.
import { api } from "../api";
import { fill, h, link } from "../dom";
import { identity } from "../identity";
import { EXPERIMENTS, errorText, failure, loading, plantDetail } from "./common";
import { RigStatusPanel } from "./rigstatus";
import { runTable } from "./runtable";

/** How often the start page asks whether the class demo changed (a projector shows it). */
const DEMO_REFRESH_MS = 5000;

export async function home(root: HTMLElement): Promise<() => void> {
  const demo = h("div", { "data-testid": "demo-slot" });
  const rigSlot = h("div");
  let rig: RigStatusPanel | null = null;
  const cards = h("div.cards", loading());
  const recent = h("div", loading());
  const recentMsg = h("p.error", { role: "alert" });
  root.append(
    h("header.page.hero", h("h1", "E-Lab"), h("p.lead", "A web laboratory for control engineering. Pick a plant and an experiment; the response draws itself live as the run goes.")),
    demo,
    rigSlot,
    h("section", { "aria-labelledby": "plants-h" }, h("h2#plants-h", "Plants and experiments"), cards),
    h("section", { "aria-labelledby": "runs-h" }, h("h2#runs-h", "Recent runs"), recentMsg, recent),
  );
  const showDemo = async () => {
    const banner = await demoBanner(showDemo).catch(() => null);
    const shown = demo.firstElementChild as HTMLElement | null;
    if (banner?.dataset.key !== shown?.dataset.key) fill(demo, banner); // unchanged: keep focus where it is
  };
  const timer = setInterval(() => void showDemo(), DEMO_REFRESH_MS);
  await showDemo();
  let names: Record<string, string> = {};
  try {
    const plants = await api.plants();
    names = Object.fromEntries(plants.map((p) => [p.id, p.name]));
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
    // a plant runs on the rig only where the server has one: its status, else nothing
    const onRig = plants.find((p) => p.modes.includes("rig"));
    if (onRig) {
      rig = new RigStatusPanel(h("p.hint", `Run on it from the ${onRig.name.toLowerCase()}'s `, ...onRig.experiments.flatMap((e, i) => [i ? (i === onRig.experiments.length - 1 ? " or " : ", ") : "", link(`/plants/${onRig.id}/${e}`, EXPERIMENTS[e]?.title.toLowerCase() ?? e)]), ": choose “Real rig”."));
      fill(rigSlot, rig.root);
    }
  } catch (err) {
    fill(cards, failure(err));
  }
  const showRecent = async () => {
    try {
      const list = await api.runs({ limit: 10 });
      const actions = { changed: () => void showRecent(), failed: (m: string) => fill(recentMsg, m) };
      fill(recent, list.runs.length ? runTable(list.runs, actions, names) : h("p.muted", "No runs yet: start one from an experiment above."), list.total > list.runs.length ? h("p", link("/runs", `All ${list.total} runs`)) : null);
    } catch (err) {
      fill(recent, failure(err));
    }
  };
  await showRecent();
  return () => {
    clearInterval(timer);
    rig?.destroy();
  };
}

/** The pinned class demo as a banner (null: none pinned); instructors may unpin it. */
async function demoBanner(changed: () => Promise<void>): Promise<HTMLElement | null> {
  const [info, me] = await Promise.all([api.demo(), identity.get().catch(() => null)]);
  const run = info.run;
  if (!run) return null;
  const plant = await plantDetail(run.plant).then((p) => p.name, () => run.plant);
  const msg = h("p.error", { role: "alert" });
  const unpin = async () => {
    try {
      await api.unpinDemo();
      await changed();
    } catch (err) {
      fill(msg, errorText(err));
    }
  };
  return h(
    "section.demo-banner",
    { "aria-labelledby": "demo-h", "data-testid": "demo-banner", "data-run": run.id, "data-key": `${run.id} ${run.status}` },
    h("h2#demo-h", "Class demo"),
    h(
      "p",
      link(`/runs/${run.id}`, `${plant}: ${EXPERIMENTS[run.experiment]?.title.toLowerCase() ?? run.experiment}`),
      " ",
      h("span.badge", { "data-state": run.status }, run.status),
      h("span.muted", ` · ${run.owner === info.pinned_by ? `by ${run.owner}` : `run by ${run.owner}, pinned by ${info.pinned_by ?? "an instructor"}`}`),
    ),
    me?.role === "instructor" ? h("button", { type: "button", onclick: () => void unpin() }, "Unpin") : null,
    msg,
  );
}
