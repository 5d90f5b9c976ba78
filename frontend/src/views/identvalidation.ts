// The optional validation record of an identification panel: a second file of the same
// experiment to validate on instead of the rest of the data. While one is chosen the
// estimation share is not used, and its field is disabled.
import { fill, h } from "../dom";
import type { NumberField } from "../forms";

const NONE = "Optional. Without one, the data after the estimation share validate.";

export class ValidationFile {
  readonly root: HTMLElement;
  private readonly input: HTMLInputElement;
  private readonly remove: HTMLButtonElement;
  private readonly note = h("small.hint", { "data-testid": "validation-note" }, NONE);

  /** `pre`: the panel's element id prefix; `split`: its estimation share field; `columns`:
   * which columns the file must have, in words. */
  constructor(
    pre: string,
    private readonly split: NumberField,
    columns: string,
  ) {
    const id = `${pre}-validation-file`;
    this.input = h("input", { type: "file", id, accept: ".csv,.txt,.dat,.json", "data-testid": "validation-file", onchange: () => this.update() });
    this.remove = h("button.link", { type: "button", hidden: true, "data-testid": "validation-remove", onclick: () => ((this.input.value = ""), this.update()) }, "Remove");
    this.root = h("div.field", h("label", { for: id }, `Validation file (${columns})`), h("div.field-row", this.input, this.remove), this.note);
  }

  /** The chosen file, or null (validate on the data after the estimation share). */
  get file(): File | null {
    return this.input.files?.[0] ?? null;
  }

  private update(): void {
    const file = this.file;
    this.split.input.disabled = file !== null;
    if (file && this.split.value === null) this.split.value = 0.5; // no error under a field one cannot edit
    this.remove.hidden = file === null;
    fill(this.note, file ? `Validation uses the separate record ${file.name}: the estimation share is not used, and “remove the mean” takes the data's means off both.` : NONE);
  }
}
