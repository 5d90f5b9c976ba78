// "Run on the real rig" in an experiment's form: simulation or the rig (only for a plant
// whose modes include it, on a server with a rig). Choosing the rig shows the queue and
// the steps to a run: join the queue, arm the rig when your turn comes, then the form's
// own Start sends the run in mode "rig"; countdowns for arming and for the slot; leave.
import { api, ApiError } from "../api";
import { fill, h } from "../dom";
import type { PlantDetail, RigQueueInfo } from "../protocol.gen";
import { placeText, rigButtons, rigStep, rigSummary, startBlocker, startRefusal, type RigStep } from "../rig";
import { rigFeed, type RigFeedState } from "../rigfeed";
import { kindBadge } from "../rigrun";
import { countdown, queueOf, queueOp, Ticker } from "./rigstatus";

export type RunMode = "simulation" | "rig";

const STEPS: [RigStep[], string][] = [
  [["join"], "Join the rig's queue"],
  [["wait", "arm"], "Arm the rig when it is your turn"],
  [["start", "running"], "Start (the button below) — the run goes on the rig"],
];

export class RigModeChoice {
  readonly root: HTMLElement;
  private readonly radios: Record<RunMode, HTMLInputElement>;
  private readonly rigLabel = h("span");
  private readonly queueBox = h("div.rig-queue", { hidden: true, "data-testid": "rig-queue" });
  private readonly status = h("p.rig-line", { "data-testid": "rig-line" });
  private readonly you = h("p.rig-you", { "data-testid": "rig-you", "aria-live": "polite" });
  private readonly steps: HTMLLIElement[];
  private readonly armBy = h("span.rig-timer", { hidden: true }, "Arm within ", countdown(null), " or the turn passes on.");
  private readonly slotEnds = h("span.rig-timer", { hidden: true }, "Your slot ends in ", countdown(null), ".");
  private readonly buttons: Record<"join" | "arm" | "leave", HTMLButtonElement>;
  private readonly msg = h("p.error", { role: "alert", "data-testid": "rig-error" });
  private readonly ticker: Ticker;
  private readonly unsubscribe: (() => void) | null = null;
  private last: RigQueueInfo | null = null;

  /** `available` false: the plant has no rig here, and `root` is null-like (empty, hidden). */
  readonly available: boolean;

  constructor(
    plant: PlantDetail,
    idPrefix: string,
    /** the mode changed (the form disables what a rig run does not take) */
    private readonly onMode: (mode: RunMode) => void = () => undefined,
  ) {
    this.available = plant.modes.includes("rig");
    const radio = (mode: RunMode) => h("input", { type: "radio", name: `${idPrefix}-mode`, id: `${idPrefix}-mode-${mode}`, value: mode, checked: mode === "simulation", onchange: () => this.modeChanged() });
    this.radios = { simulation: radio("simulation"), rig: radio("rig") };
    const button = (label: string, action: (b: HTMLButtonElement) => void, cls = "") => {
      const b: HTMLButtonElement = h("button", { type: "button", class: cls, hidden: true, onclick: () => action(b) }, label);
      return b;
    };
    this.buttons = {
      join: button("Join the queue", (b) => void queueOp(api.joinRig, this.msg, b), "primary"),
      arm: button("Arm the rig", (b) => void queueOp(api.armRig, this.msg, b), "primary"),
      leave: button("Leave the queue", (b) => void this.leave(b)),
    };
    this.steps = STEPS.map(([, text], i) => h("li", h("span.step-n", `${i + 1}`), " ", text));
    this.steps[0].append(" ", this.buttons.join);
    this.steps[1].append(" ", this.buttons.arm, " ", this.armBy);
    this.steps[2].append(" ", this.slotEnds);
    fill(this.queueBox, this.status, this.you, h("ol.rig-steps", ...this.steps), h("div.actions", this.buttons.leave), this.msg);
    this.root = h(
      "fieldset.rig-mode",
      { hidden: !this.available, "data-testid": "rig-mode" },
      h("legend", "Where to run"),
      h("div.choices", h("label.check", this.radios.simulation, " Simulation"), h("label.check", this.radios.rig, " Real rig ", this.rigLabel)),
      this.queueBox,
    );
    this.ticker = new Ticker(this.queueBox);
    // the queue is followed while the choice is on the page: "Real rig" says whether it
    // is emulated before anyone picks it
    if (this.available) this.unsubscribe = rigFeed.subscribe((s) => this.show(s));
  }

  get mode(): RunMode {
    return this.available && this.radios.rig.checked ? "rig" : "simulation";
  }

  /** Back to simulation (a run the rig cannot take). */
  useSimulation(): void {
    if (this.radios.simulation.checked) return;
    this.radios.simulation.checked = true;
    this.modeChanged();
  }

  /** Why Start cannot send a rig run now, shown beside the queue (null: it may, or the
   * mode is simulation). */
  blocker(): string | null {
    if (this.mode !== "rig") return null;
    const why = this.last ? startBlocker(this.last) : "The rig's queue is not known yet: wait a moment, then Start.";
    fill(this.msg, why);
    return why;
  }

  /** A rig run was refused: say why and what to do, beside the queue. */
  refused(err: unknown): void {
    if (err instanceof ApiError && (err.status === 409 || err.status === 503)) fill(this.msg, startRefusal(err.status, err.message));
    void rigFeed.refresh();
  }

  /** A rig run started: the queue shows it at once. */
  started(): void {
    fill(this.msg);
    void rigFeed.refresh();
  }

  private modeChanged(): void {
    const rig = this.mode === "rig";
    this.queueBox.hidden = !rig;
    fill(this.msg);
    this.onMode(this.mode);
  }

  private show(s: RigFeedState): void {
    if (s.kind === "none") {
      fill(this.status, "This server has no rig any more: run in simulation.");
      return;
    }
    const got = queueOf(s);
    if (!got) return fill(this.status, `The rig's queue could not be read: ${s.kind === "error" ? s.message : ""}`);
    const q = got.q;
    this.last = q;
    const sum = rigSummary(q);
    fill(this.rigLabel, kindBadge(q.rig.emulated));
    fill(this.status, h("span.badge.rig-state", { "data-condition": sum.condition }, sum.headline), " ", h("span.muted", sum.details.join(" · ")), s.kind === "error" ? h("span.notice", ` (not updated: ${s.message})`) : null);
    fill(this.you, placeText(q) ?? "You are not in the queue.");
    const step = rigStep(q);
    this.queueBox.dataset.step = step;
    STEPS.forEach(([on], i) => {
      const li = this.steps[i];
      if (on.includes(step)) li.setAttribute("aria-current", "step");
      else li.removeAttribute("aria-current");
      li.dataset.done = String(STEPS.findIndex(([s2]) => s2.includes(step)) > i);
    });
    const show = rigButtons(q, "student");
    this.buttons.join.hidden = !show.join;
    this.buttons.arm.hidden = !show.arm;
    this.buttons.leave.hidden = !show.leave;
    this.setTimer(this.armBy, step === "arm" ? q.you.arm_by : null);
    this.setTimer(this.slotEnds, q.you.driving ? q.slot_ends_at : null);
    this.ticker.seen(q, got.at);
  }

  private setTimer(el: HTMLElement, until: number | null): void {
    el.hidden = until === null;
    (el.querySelector("[data-until]") as HTMLElement).dataset.until = String(until ?? "");
  }

  private async leave(b: HTMLButtonElement): Promise<void> {
    if (this.last?.phase === "running" && this.last.you.driving && !confirm("Leaving the queue stops your run on the rig. Leave?")) return;
    await queueOp(api.leaveRig, this.msg, b);
  }

  destroy(): void {
    this.unsubscribe?.();
    this.ticker.destroy();
  }
}
