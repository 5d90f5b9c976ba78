// The caller's uploaded controllers as a table: name, format, when, the report's verdict,
// and Run and Delete for each. A Python controller is run from the start of a run (it is
// never swapped into a live one), so Run is all there is for it too.
import type { UploadedController } from "../api";
import { formatText, verdictWord } from "../controllertext";
import { h } from "../dom";

export interface ControllerActions {
  run(c: UploadedController): void;
  remove(c: UploadedController, button: HTMLButtonElement): void;
}

export function controllerTable(controllers: UploadedController[], actions: ControllerActions): HTMLElement {
  return h(
    "table.controllers",
    h("thead", h("tr", h("th", "Name"), h("th", "Format"), h("th", "Uploaded"), h("th", "Closed loop"), h("th", h("span.visually-hidden", "Actions")))),
    h(
      "tbody",
      ...controllers.map((c) => {
        const remove = h("button.danger", { type: "button", "aria-label": `Delete controller ${c.name}`, onclick: () => actions.remove(c, remove) }, "Delete");
        return h(
          "tr",
          { "data-controller": c.id, "data-format": c.format },
          h("td", c.name),
          h("td", formatText(c.format)),
          h("td", new Date(c.created_at * 1000).toLocaleString()),
          h("td", h("span.badge", { "data-stable": String(c.report.stable) }, verdictWord(c.report))),
          h("td.actions-cell", h("button", { type: "button", "aria-label": `Run controller ${c.name}`, onclick: () => actions.run(c) }, "Run"), " ", remove),
        );
      }),
    ),
  );
}
