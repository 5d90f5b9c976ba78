// A plant's page: its description with rendered equations, parameters, printable copy.
import { h, link, saveText } from "../dom";
import { renderMarkdown, tex } from "../markdown";
import type { PlantDetail } from "../protocol.gen";
import { fmt } from "../units";
import { EXPERIMENTS, failure, loading, pageHeader, plantDetail, plantTabs } from "./common";
import { RigStatusPanel } from "./rigstatus";

export async function plantPage(root: HTMLElement, params: Record<string, string>): Promise<(() => void) | void> {
  root.append(loading());
  let plant: PlantDetail;
  try {
    plant = await plantDetail(params.id);
  } catch (err) {
    root.replaceChildren(failure(err));
    return;
  }
  const description = h("article.description.panel");
  const rig = plant.modes.includes("rig") ? new RigStatusPanel() : null;
  description.innerHTML = renderMarkdown(plant.description);
  root.replaceChildren(
    pageHeader(plant.name, [[`/plants/${plant.id}`, plant.name]], h("p.lead", plant.summary)),
    plantTabs(plant, `/plants/${plant.id}`),
    rig?.root ?? "",
    h(
      "div.toolbar.no-print",
      h("button", { type: "button", onclick: () => window.print() }, "Print"),
      h("button", { type: "button", onclick: () => saveText(`${plant.id}.md`, plant.description, "text/markdown") }, "Download description (.md)"),
    ),
    description,
    h("section.panel", h("h2", "Parameters"), parameters(plant)),
    h("section.panel.no-print", h("h2", "Experiments"), h("ul.experiments", ...plant.experiments.map((e) => h("li", link(`/plants/${plant.id}/${e}`, EXPERIMENTS[e]?.title ?? e), " — ", EXPERIMENTS[e]?.blurb ?? "")))),
  );
  return rig ? () => rig.destroy() : undefined;
}

function matrix(name: string, m: number[][]): HTMLElement {
  const body = m.map((row) => row.map((v) => fmt(v, 5)).join(" & ")).join(" \\\\ ");
  const span = h("span.math");
  span.innerHTML = tex(`${name} = \\begin{bmatrix} ${body} \\end{bmatrix}`, true);
  return span;
}

function parameters(p: PlantDetail): HTMLElement {
  const ctrl = p.predefined;
  const ctrlText = ctrl.kind === "state_feedback" ? `K = [${ctrl.K.map((k) => fmt(k, 6)).join(", ")}]` : ctrl.kind === "pid" ? `Kp = ${ctrl.Kp}, Ki = ${ctrl.Ki}, Kd = ${ctrl.Kd}` : ctrl.kind;
  const row = (k: string, v: string) => h("tr", h("th", { scope: "row" }, k), h("td", v));
  return h(
    "div",
    h("div.matrices", matrix("A", p.A), matrix("B", p.B), matrix("C", p.C), matrix("D", p.D)),
    h(
      "table.params",
      h(
        "tbody",
        row("States", p.states.map((s) => `${s.label} (${s.unit})`).join(", ")),
        row("Input", p.inputs.map((s) => `${s.label} (${s.unit})`).join(", ")),
        row("Outputs", p.outputs.map((s) => `${s.label} (${s.unit})`).join(", ")),
        row("Actuator limit", `±${p.u_max} ${p.inputs[0]?.unit ?? "V"}${p.saturate ? "" : " (not applied by default)"}`),
        row("Sample time", `${p.Ts * 1000} ms`),
        row("Predefined controller", `${ctrlText} — ${p.predefined_design}`),
        row("Modes", p.modes.join(", ")),
      ),
    ),
  );
}
