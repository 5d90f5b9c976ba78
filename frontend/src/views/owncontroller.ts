// "Your own controller" on a plant's design page: templates to download, a controller file
// to upload (picked or dropped on the panel), its report, a run of it with the predefined
// controller's run under the same reference drawn over it, and the caller's controllers.
// A Python controller (.py) is checked by trial runs in its sandbox, and its run shows its
// compute time per step once it ended.
import { api, templateUrl, type UploadedController } from "../api";
import { FileRefused, MAX_FILE_BYTES, kib, uploadOf, type ControllerFormat } from "../controllerfile";
import { fill, h, link } from "../dom";
import { durationField, SignalForm, StartOptions } from "../experiment";
import { FieldSet } from "../forms";
import type { PlantDetail, RunCreate, RunInfo } from "../protocol.gen";
import { RunPanel } from "../runpanel";
import { controllerTable } from "./controllerlist";
import { controllerReport } from "./controllerreport";
import { errorText, loading, showApiError } from "./common";
import { RigModeChoice } from "./rigmode";

const TEMPLATES: [ControllerFormat, string][] = [
  ["toml", "TOML (with comments)"],
  ["json", "JSON"],
  ["mat", "MATLAB .mat"],
  ["npz", "NumPy .npz"],
  ["py", "Python (.py)"],
];
const ID = "own";

export class OwnControllerView {
  readonly root: HTMLElement;
  private readonly panel: HTMLElement;
  private readonly fileInput = h("input", { type: "file", id: `${ID}-file`, accept: ".toml,.json,.mat,.npz,.py", "aria-describedby": `${ID}-file-hint` });
  private readonly uploadMsg = h("p.error", { role: "alert", "data-testid": "upload-error" });
  private readonly status = h("p.status", { "aria-live": "polite", "data-testid": "upload-status" });
  private readonly reportBox = h("div", { hidden: true });
  private readonly listBox = h("div", { "data-testid": "controller-list" });
  private readonly runBox = h("section.panel.wide", { hidden: true, "aria-label": "run of your controller" });
  private readonly reference: SignalForm;
  private readonly runFields = new FieldSet();
  private readonly startOptions = new StartOptions(ID);
  private readonly runMsg = h("p.error", { role: "alert" });
  private readonly runForm: HTMLFormElement;
  private readonly where: RigModeChoice;
  private selected: UploadedController | null = null;
  private run: RunPanel | null = null;
  /** a file dropped beside the panel would make the browser open it, leaving the page */
  private readonly elsewhere = (ev: DragEvent) => {
    if (ev.defaultPrevented || !ev.dataTransfer?.types.includes("Files")) return;
    ev.preventDefault();
    ev.dataTransfer.dropEffect = "none";
  };

  constructor(readonly plant: PlantDetail) {
    const unit = plant.outputs.find((o) => o.name === plant.reference_output)?.unit ?? "";
    this.reference = new SignalForm("signal", "Reference", ["square", "step", "sine"], unit, plant.default_signal, undefined, ID);
    this.runFields.add(durationField(plant.default_duration, undefined, ID));
    this.where = new RigModeChoice(plant, ID);
    this.runForm = h(
      "form.run-form",
      { novalidate: true, "aria-label": "run your controller", onsubmit: (ev: Event) => (ev.preventDefault(), this.selected && void this.runIt(this.selected)) },
      h("h3", "Run it"),
      h("p.hint", "Starts your controller and, dotted on the same plot, the predefined controller under the same reference (simulation). On the real rig: your controller on the rig, and dotted its simulation."),
      this.where.root,
      this.reference.root,
      h("div.grid", ...[...this.runFields.fields.values()].map((f) => f.root)),
      this.startOptions.root,
      h("div.actions", h("button.primary", { type: "submit" }, "Run it")),
      this.runMsg,
    );
    this.fileInput.addEventListener("change", () => {
      const file = this.fileInput.files?.[0];
      if (file) void this.upload(file);
      this.fileInput.value = ""; // the same file again is a new upload
    });
    this.panel = h(
      "section.panel.wide.own-controller",
      { "aria-labelledby": `${ID}-title`, "data-testid": "own-controller" },
      h("h2", { id: `${ID}-title` }, "Your own controller"),
      h(
        "div.two",
        h("div", ...this.uploadPart()),
        h("div", h("h3", "Your controllers"), this.listBox),
      ),
      this.uploadMsg,
      this.status,
      this.reportBox,
    );
    this.dropTarget(this.panel);
    window.addEventListener("dragover", this.elsewhere);
    window.addEventListener("drop", this.elsewhere);
    this.root = h("div", this.panel, this.runBox);
    void this.loadList();
  }

  private uploadPart(): (HTMLElement | string)[] {
    const p = this.plant;
    const links = TEMPLATES.map(([format, label]) => h("a", { href: templateUrl(p.id, format), download: `${p.id}-controller.${format}`, "data-format": format }, label));
    return [
      h("p", "Bring a controller as a file: state feedback, PID, any linear controller or open loop, or Python code (a class Controller with step(t, y, r) → u, run in a sandbox). Start from a template: it holds this plant's predefined controller, every field explained."),
      h("p.templates", "Templates: ", ...links.flatMap((a, i) => (i ? [" · ", a] : [a])), " · ", link("/help/controllers", "every field explained")),
      h(
        "div.dropzone",
        h("label", { for: this.fileInput.id }, "Upload a controller file"),
        this.fileInput,
        h("small.hint", { id: `${ID}-file-hint` }, `.toml, .json, .mat (v4 to v7), .npz or .py, at most ${kib(MAX_FILE_BYTES)}; or drop the file on this panel`),
      ),
    ];
  }

  /** Files dropped anywhere on the panel are uploaded like picked ones. */
  private dropTarget(el: HTMLElement): void {
    const hasFiles = (ev: DragEvent) => ev.dataTransfer?.types.includes("Files") ?? false;
    el.addEventListener("dragover", (ev) => {
      if (!hasFiles(ev)) return;
      ev.preventDefault();
      if (ev.dataTransfer) ev.dataTransfer.dropEffect = "copy";
      el.classList.add("dragover");
    });
    el.addEventListener("dragleave", (ev) => {
      if (!(ev.relatedTarget instanceof Node && el.contains(ev.relatedTarget))) el.classList.remove("dragover");
    });
    el.addEventListener("drop", (ev) => {
      el.classList.remove("dragover");
      const files = ev.dataTransfer?.files;
      if (!files?.length) return;
      ev.preventDefault();
      if (files.length > 1) return void fill(this.uploadMsg, `${files.length} files dropped: drop one controller file at a time. Nothing was sent.`);
      void this.upload(files[0]);
    });
  }

  private async upload(file: File): Promise<void> {
    fill(this.uploadMsg);
    fill(this.status, `Checking ${file.name}…`);
    let c: UploadedController;
    try {
      c = await api.uploadController(await uploadOf(file, this.plant.id));
    } catch (err) {
      fill(this.status);
      fill(this.uploadMsg, `${file.name} was refused: ${err instanceof FileRefused ? err.message : errorText(err)}`);
      // the report on screen was another file's: it goes, so that nothing reads as this
      // file's (the earlier controller stays in "Your controllers", to open again)
      this.selected = null;
      this.reportBox.hidden = true;
      fill(this.reportBox);
      return;
    }
    const verdict = c.report.domain === "trial" ? (c.report.stable ? "its trial runs ran through" : "its trial runs failed") : c.report.stable ? "stable" : "unstable";
    fill(this.status, `Uploaded ${file.name} as “${c.name}”: ${verdict}, ${c.report.rig_ready ? "ready for the real rig" : "kept off the real rig"}.`);
    this.select(c);
    await this.loadList();
  }

  private select(c: UploadedController): void {
    this.selected = c;
    fill(this.runMsg);
    fill(this.reportBox, controllerReport(c, this.plant), this.runForm);
    this.reportBox.hidden = false;
  }

  private async loadList(): Promise<void> {
    if (!this.listBox.firstChild) fill(this.listBox, loading());
    try {
      const { controllers } = await api.controllers(this.plant.id);
      const actions = { run: (c: UploadedController) => (this.select(c), void this.runIt(c)), remove: (c: UploadedController, b: HTMLButtonElement) => void this.remove(c, b) };
      fill(this.listBox, controllers.length ? controllerTable(controllers, actions) : h("p.muted", "None yet: upload one on the left."));
    } catch (err) {
      fill(this.listBox, h("p.error", { role: "alert" }, `Your controllers could not be listed: ${errorText(err)}`));
    }
  }

  private async remove(c: UploadedController, button: HTMLButtonElement): Promise<void> {
    if (!confirm(`Delete the controller “${c.name}”? Runs made with it keep their record of it.`)) return;
    button.disabled = true;
    fill(this.uploadMsg);
    try {
      await api.deleteController(c.id);
      fill(this.status, `Deleted “${c.name}”.`);
      if (this.selected?.id === c.id) {
        this.selected = null;
        this.reportBox.hidden = true;
        fill(this.reportBox);
      }
    } catch (err) {
      fill(this.uploadMsg, `“${c.name}” was not deleted: ${errorText(err)}`);
      button.disabled = false;
    }
    await this.loadList();
  }

  /** Run `c`, and the predefined controller under the same reference, drawn over it. */
  private async runIt(c: UploadedController): Promise<void> {
    fill(this.runMsg);
    const signal = this.reference.value();
    const v = this.runFields.values();
    if (!signal || !v) return void fill(this.runMsg, "Please correct the marked fields; nothing was sent.");
    const mode = this.where.mode;
    if (this.where.blocker()) return void fill(this.runMsg, "Nothing was sent: see the rig's steps above.");
    const same: RunCreate = { plant: this.plant.id, experiment: "design", signal, duration: v.get("duration")!, pace: "realtime", private: this.startOptions.private };
    const previous = this.run;
    let info: RunInfo;
    try {
      info = await api.createRun({ ...same, mode, controller_id: c.id });
      if (mode === "rig") this.where.started();
    } catch (err) {
      showApiError(err, [this.reference.fields, this.runFields], this.runMsg);
      if (mode === "rig") this.where.refused(err);
      return;
    }
    // beside it: the predefined controller's simulation, or on the rig its own simulation
    const other = mode === "rig" ? { req: { ...same, controller_id: c.id }, label: "its simulation", title: " on the rig against its simulation" } : { req: { ...same, controller: { kind: "predefined" as const } }, label: "predefined controller", title: " against the predefined controller" };
    let companion: RunInfo | null = null;
    let why = "";
    try {
      companion = await api.createRun(other.req);
    } catch (err) {
      why = errorText(err);
    }
    previous?.destroy();
    this.run = new RunPanel(info, this.plant, { awaitCompute: c.format === "py" });
    if (companion) this.run.overlay(companion, other.label);
    fill(
      this.runBox,
      h("h2", `${c.name}${companion ? other.title : ""}`),
      why ? h("p.notice", `The run to draw beside it (${other.label}) did not start, so yours runs alone: ${why}`) : null,
      this.run.root,
    );
    this.runBox.hidden = false;
    this.runBox.scrollIntoView({ block: "nearest" });
    try {
      await this.startOptions.retire(previous);
      await this.startOptions.retire(previous?.overlaid ?? null);
    } catch (err) {
      fill(this.runMsg, `The previous run goes on: ${errorText(err)}`);
    }
  }

  destroy(): void {
    window.removeEventListener("dragover", this.elsewhere);
    window.removeEventListener("drop", this.elsewhere);
    this.run?.destroy();
    this.where.destroy();
  }
}
