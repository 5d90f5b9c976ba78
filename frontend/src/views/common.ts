// Pieces every view uses: page header, loading and error states, the plant cache.
import { api, ApiError } from "../api";
import { csv, fill, h, link, saveText } from "../dom";
import type { FieldSet } from "../forms";
import type { PlantDetail, VerdictOut } from "../protocol.gen";

const plants = new Map<string, Promise<PlantDetail>>();

/** A plant's detail, fetched once per page load. */
export function plantDetail(id: string): Promise<PlantDetail> {
  let p = plants.get(id);
  if (!p) {
    p = api.plant(id);
    p.catch(() => plants.delete(id));
    plants.set(id, p);
  }
  return p;
}

export const EXPERIMENTS: Record<string, { title: string; blurb: string; learn: string; help: [string, string] }> = {
  analysis: {
    title: "System analysis",
    blurb: "Eigenvalues, stability, transfer functions, Bode; a closed-loop run with gains you tune live.",
    learn: "You will read a plant's model as numbers (its poles, its transfer functions, its Bode plot) and see what they predict in a closed-loop run. Changing a gain while the run goes shows how each one shapes the response.",
    help: ["glossary", "the words of the lab"],
  },
  identification: {
    title: "Identification",
    blurb: "Excite with PRBS, sine or step; record the response and download it for identification.",
    learn: "You will excite the plant, record how it answers and estimate a model from the data alone. The verdicts say whether the data and each model can be trusted, and why.",
    help: ["identification", "the methods and the verdicts"],
  },
  design: {
    title: "Controller design",
    blurb: "Design state feedback by LQR or pole placement, compare with the predefined controller, run it.",
    learn: "You will design a controller on the model, see the response it predicts, then run it and compare the run with the prediction. Your own controller (a file or Python) gets the same checks.",
    help: ["controllers", "controller files and Python"],
  },
};

/** The page's header, which also names the browser tab after the page. */
export function pageHeader(title: string, crumbs: [string, string][] = [], ...extra: (Node | string)[]): HTMLElement {
  document.title = `${title} · E-Lab`;
  const nav = h("nav.crumbs", { "aria-label": "breadcrumbs" }, link("/", "E-Lab"));
  for (const [href, text] of crumbs) nav.append(" / ", link(href, text));
  return h("header.page", nav, h("h1", title), ...extra);
}

export function failure(err: unknown): HTMLElement {
  const msg = err instanceof ApiError ? `${err.message}` : String(err);
  return h("div.panel.failure", { role: "alert" }, h("strong", "Could not load this page: "), msg, " ", link("/", "Back to the start page"));
}

/** What went wrong, in a sentence: the server's field errors, or its message. */
export function errorText(err: unknown): string {
  if (!(err instanceof ApiError)) return String(err);
  const fields = err.detail.errors.map((e) => (e.message.startsWith(e.field) ? e.message : `${e.field}: ${e.message}`));
  return fields.length ? fields.join("; ") : err.message;
}

export function loading(text = "Loading…"): HTMLElement {
  return h("p.loading", { "aria-busy": "true" }, text);
}

/** A plant's experiment page: the plant is loaded, then `build` makes the content below the
 * header and tabs and returns its cleanup; a failure to load shows instead. */
export async function experimentPage(root: HTMLElement, plantId: string, experiment: string, build: (plant: PlantDetail) => { content: HTMLElement; cleanup: () => void }): Promise<() => void> {
  root.append(loading());
  let plant: PlantDetail;
  try {
    plant = await plantDetail(plantId);
  } catch (err) {
    root.replaceChildren(failure(err));
    return () => undefined;
  }
  const { content, cleanup } = build(plant);
  const known = EXPERIMENTS[experiment];
  const title = known?.title.toLowerCase() ?? experiment;
  const learn = known ? h("p.lead.learn", { "data-testid": "learn" }, known.learn, " ", link(`/help/${known.help[0]}`, `Help: ${known.help[1]}`), ".") : "";
  // a model whose actuator is not limited says so where its runs start (its u can reach
  // tens of volts, and a run marks that "beyond the actuator")
  const unlimited = plant.saturate ? "" : h("p.note.saturation-off", { "data-testid": "saturation-off" }, `This model's input is not limited: u may go beyond the actuator's ±${plant.u_max} V (a real motor would saturate there). A run that does says so.`);
  root.replaceChildren(pageHeader(`${plant.name}: ${title}`, [[`/plants/${plant.id}`, plant.name]], learn, unlimited), plantTabs(plant, `/plants/${plant.id}/${experiment}`), content);
  return cleanup;
}

/** Tabs between a plant's pages. */
export function plantTabs(plant: PlantDetail, current: string): HTMLElement {
  const tabs: [string, string][] = [[`/plants/${plant.id}`, "About"], ...plant.experiments.map((e): [string, string] => [`/plants/${plant.id}/${e}`, EXPERIMENTS[e]?.title ?? e])];
  return h(
    "nav.tabs",
    { "aria-label": `${plant.name} pages` },
    ...tabs.map(([href, text]) => {
      const a = link(href, text);
      if (href === current) a.setAttribute("aria-current", "page");
      return a;
    }),
  );
}

/** Show an API error next to the fields it names (the rest under the form). */
export function showApiError(err: unknown, sets: FieldSet[], out: HTMLElement): void {
  for (const s of sets) s.clearErrors();
  if (!(err instanceof ApiError)) {
    fill(out, String(err));
    return;
  }
  let rest = err.fieldMessages();
  for (const s of sets) rest = s.showErrors(rest);
  const unclaimed = [...rest].map(([f, m]) => (m.startsWith(f) ? m : `${f}: ${m}`));
  fill(out, unclaimed.length ? unclaimed.join("; ") : err.detail.errors.length ? "Please correct the marked fields; nothing was started." : err.message);
}

/** A button that saves a plot's data as CSV. */
export function downloadButton(filename: string, header: string[], columns: ArrayLike<number | null>[]): HTMLButtonElement {
  return h("button.download.link", { type: "button", onclick: () => saveText(filename, csv(header, columns)) }, `Download data (${filename})`);
}

const LEVEL_WORDS: Record<VerdictOut["level"], string> = { good: "good", caution: "caution", poor: "poor" };

/** Identification's verdicts as a list: each finding with its level and what to change. */
export function verdictList(verdicts: VerdictOut[], testid: string): HTMLElement {
  return h(
    "ul.verdicts",
    { "data-testid": testid },
    ...verdicts.map((v) => h(`li.verdict-${v.level}`, { "data-topic": v.topic }, h("strong", `${LEVEL_WORDS[v.level]}: `), v.finding, v.advice ? h("span.advice", ` — ${v.advice}`) : "")),
  );
}
