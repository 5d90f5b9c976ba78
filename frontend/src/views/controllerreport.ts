// An uploaded controller's report as the page shows it: its name and law, the verdict, the
// closed-loop poles, the margins, the peak control against the actuator, what keeps it off
// the real rig (problems, red) and what to look out for (warnings, amber).
import type { UploadedController } from "../api";
import { h } from "../dom";
import { lawText, marginText, peakText, poleList, verdictText } from "../controllertext";
import type { PlantDetail } from "../protocol.gen";

export function controllerReport(c: UploadedController, plant: PlantDetail): HTMLElement {
  const r = c.report;
  const law = lawText(c.controller);
  const margins = marginText(r);
  const referenceUnit = plant.outputs.find((o) => o.name === plant.reference_output)?.unit ?? "";
  const peak = peakText(r, referenceUnit, plant.inputs[0]?.unit ?? "V");
  const row = (label: string, ...value: (Node | string)[]) => h("tr", h("th", { scope: "row" }, label), h("td", ...value));
  return h(
    "div.controller-report",
    { "data-controller": c.id, "data-testid": "controller-report" },
    h("h3", c.name, " ", h("span.badge", { "data-stable": String(r.stable) }, r.stable ? "stable" : "unstable")),
    h("p.muted", `${c.format.toUpperCase()} file, uploaded ${new Date(c.created_at * 1000).toLocaleString()} by ${c.mine ? "you" : c.owner}`),
    h(
      "table.params.report",
      h(
        "tbody",
        row("Law", law.kind),
        law.law ? row("Gains", h("span.mono", { "data-testid": "controller-law" }, law.law)) : null,
        row("Closed loop", h("strong", { "data-testid": "verdict", class: r.stable ? "ok" : "bad" }, verdictText(r))),
        row(r.domain === "z" ? "Closed-loop poles, in z" : "Closed-loop poles, in s", h("span.mono", { "data-testid": "poles" }, poleList(r.poles).join(", "))),
        row("Margins", `gain margin ${margins.gain}, phase margin ${margins.phase} (loop broken at the plant input)`),
        row("Peak |u|", h("span", { "data-testid": "peak-u", class: peak.over ? "warn" : null }, peak.text)),
        row("Real rig", h("span", { "data-testid": "rig-ready" }, r.rig_ready ? "ready: nothing keeps it off the real rig" : "not ready: the problems below keep it off the real rig")),
      ),
    ),
    r.problems.length ? h("div.problems", h("h4", "Problems: they keep it off the real rig (in simulation it runs anyway)"), h("ul", ...r.problems.map((p) => h("li", p)))) : null,
    r.warnings.length ? h("div.warnings", h("h4", "Warnings"), h("ul", ...r.warnings.map((w) => h("li", w)))) : null,
  );
}
