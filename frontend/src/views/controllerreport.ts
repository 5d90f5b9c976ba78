// An uploaded controller's report as the page shows it: its name and law, the verdict, the
// closed-loop poles, the margins, the peak control against the actuator, what keeps it off
// the real rig (problems, red) and what to look out for (warnings, amber). A Python
// controller has no poles or margins: it was checked by trial runs in its sandbox, and its
// report says what they ran and its compute time per step.
import type { UploadedController } from "../api";
import { h } from "../dom";
import { computeText, lawText, marginText, peakText, poleList, verdictText, verdictWord } from "../controllertext";
import type { PlantDetail } from "../protocol.gen";

export function controllerReport(c: UploadedController, plant: PlantDetail): HTMLElement {
  const r = c.report;
  const referenceUnit = plant.outputs.find((o) => o.name === plant.reference_output)?.unit ?? "";
  const trial = r.domain === "trial";
  // a trial that failed has no peak to speak of (it did not run through)
  const peak = trial && r.peak_u === null ? { text: "none: the trial did not run through", over: false } : peakText(r, referenceUnit, plant.inputs[0]?.unit ?? "V");
  const row = (label: string, ...value: (Node | string)[]) => h("tr", h("th", { scope: "row" }, label), h("td", ...value));
  let rows: (HTMLElement | null)[];
  if (c.controller === null || trial) {
    rows = [
      row("Law", "Python code: class Controller, step(t, y, r) → u once per sample, run in a sandbox"),
      row("Checked by", h("span", { "data-testid": "trial" }, `trial runs in its sandbox: ${r.trial ?? "—"}`)),
      row("Trial", h("strong", { "data-testid": "verdict", class: r.stable ? "ok" : "bad" }, verdictText(r))),
    ];
  } else {
    const law = lawText(c.controller);
    const margins = marginText(r);
    rows = [
      row("Law", law.kind),
      law.law ? row("Gains", h("span.mono", { "data-testid": "controller-law" }, law.law)) : null,
      row("Closed loop", h("strong", { "data-testid": "verdict", class: r.stable ? "ok" : "bad" }, verdictText(r))),
      row(r.domain === "z" ? "Closed-loop poles, in z" : "Closed-loop poles, in s", h("span.mono", { "data-testid": "poles" }, poleList(r.poles).join(", "))),
      row("Margins", `gain margin ${margins.gain}, phase margin ${margins.phase} (loop broken at the plant input)`),
    ];
  }
  return h(
    "div.controller-report",
    { "data-controller": c.id, "data-testid": "controller-report", "data-domain": r.domain },
    h("h3", c.name, " ", h("span.badge", { "data-stable": String(r.stable) }, verdictWord(r))),
    h("p.muted", `${c.format === "py" ? "Python" : c.format.toUpperCase()} file, uploaded ${new Date(c.created_at * 1000).toLocaleString()} by ${c.mine ? "you" : c.owner}`),
    h(
      "table.params.report",
      h(
        "tbody",
        ...rows,
        row("Peak |u|", h("span", { "data-testid": "peak-u", class: peak.over ? "warn" : null }, peak.text)),
        row("Real rig", h("span", { "data-testid": "rig-ready" }, r.rig_ready ? "ready: nothing keeps it off the real rig" : "not ready: the problems below keep it off the real rig")),
      ),
    ),
    r.compute?.steps ? h("p.compute", { "data-testid": "compute-time" }, computeText(r.compute), " (in the trial)") : null,
    r.problems.length ? h("div.problems", h("h4", "Problems: they keep it off the real rig (in simulation it runs anyway)"), h("ul", ...r.problems.map((p) => h("li", p)))) : null,
    r.warnings.length ? h("div.warnings", h("h4", "Warnings"), h("ul", ...r.warnings.map((w) => h("li", w)))) : null,
    c.code ? h("details.source", h("summary", "Source"), h("pre.request", { "data-testid": "controller-code" }, c.code)) : null,
  );
}
