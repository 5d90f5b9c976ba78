// What a run on the rig adds to its run panel: the emergency stop, big, red and always in
// view (fixed to the window's bottom) for whoever may control the run (its driver, an
// instructor) while it is live; the host loop's latency (the rig's last 10 s while it
// runs, the run's own latency channel once it is in); and, when it ends, why — a safety
// trip or an emergency stop — where nobody can miss it.
import { ENDED } from "./access";
import { api, ApiError } from "./api";
import { fill, h } from "./dom";
import type { RunInfo } from "./protocol.gen";
import { endText, latencyStats, latencyText, type RigInfo } from "./rig";
import { rigFeed } from "./rigfeed";

/** "emulated rig" (amber) or "hardware": what the rig is, wherever the rig shows. */
export function kindBadge(emulated: boolean): HTMLElement {
  return h("span.badge.rig-kind", { "data-emulated": String(emulated), title: emulated ? "An elab rig-emulator process behaving like the flexible link, not hardware" : "The real flexible link" }, emulated ? "emulated rig" : "hardware");
}

export class RigRunBar {
  readonly root: HTMLElement;
  private readonly estop: HTMLButtonElement;
  private readonly estopBar: HTMLElement;
  private readonly estopMsg = h("span.estop-msg", { role: "status", "data-testid": "estop-msg" });
  private readonly kind = h("span", "rig");
  private readonly latency = h("span", { "data-testid": "rig-latency" }, "loop latency: asking the rig…");
  private readonly ending = h("div.rig-end", { role: "alert", hidden: true, "data-testid": "rig-run-end" });
  private unsubscribe: (() => void) | null = null;

  constructor(
    private readonly run: RunInfo,
    /** the e-stop over the run's own websocket; false when it is not open */
    private readonly sendEstop: () => boolean,
  ) {
    this.estop = h(
      "button.estop",
      { type: "button", "data-testid": "estop", title: "0 V at the rig's next sample; the run ends stopped", onclick: () => void this.press() },
      "EMERGENCY STOP",
    );
    this.estopBar = h("div.estop-bar", { role: "region", "aria-label": "rig emergency stop", hidden: true }, h("span.estop-label", "Your run is on the rig"), this.estop, this.estopMsg);
    this.root = h("div.rig-run", { "data-testid": "rig-run" }, this.ending, h("p.rig-latency", "On the ", this.kind, " · ", this.latency));
    // on the page's top layer, not inside the run panel: no sticky box may cover it
    document.body.append(this.estopBar);
    this.follow(run.status);
  }

  /** The run's state now and why (the panel calls it with every change); true when the
   * reason is shown here (the panel need not repeat it). */
  follow(state: string, reason: string | null = null): boolean {
    const live = !ENDED.has(state);
    this.estopBar.hidden = !(live && this.run.can_control);
    if (live && !this.unsubscribe) this.unsubscribe = rigFeed.subscribe((s) => this.showRig(s.kind === "rig" ? s.q.rig : null));
    if (!live && this.unsubscribe) {
      this.stopWatching();
      void rigFeed.refresh(); // the seat's next step (arm again) shows at once
    }
    const end = ENDED.has(state) ? endText(state, reason) : null;
    if (end) {
      this.ending.hidden = false;
      this.ending.dataset.kind = end.kind;
      fill(this.ending, h("strong", end.title), h("p", end.text));
    }
    return end !== null;
  }

  /** The whole run is in: its latency channel (s per sample) says how the loop answered. */
  complete(latency: ArrayLike<number> | null): void {
    const st = latency ? latencyStats(latency) : null;
    if (!st) return;
    const us = (s: number) => `${Math.round(s * 1e6)} µs`;
    fill(this.latency, `this run's loop latency: p50 ${us(st.p50)} · p99 ${us(st.p99)} · max ${us(st.max)} over ${st.n.toLocaleString("en")} samples; ${st.late.toLocaleString("en")} answered later than 1 ms.`);
  }

  private showRig(rig: RigInfo | null): void {
    if (!rig) return;
    fill(this.kind, kindBadge(rig.emulated));
    const text = latencyText(rig);
    fill(this.latency, text ? `loop latency now (last 10 s): ${text}; ${rig.late_1ms.toLocaleString("en")} answers later than 1 ms since the loop started` : "loop latency: no samples answered yet");
  }

  private async press(): Promise<void> {
    const overSocket = this.sendEstop();
    fill(this.estopMsg, "Emergency stop sent…");
    try {
      await api.estopRig();
      fill(this.estopMsg, "Emergency stop: the motor is at 0 V.");
    } catch (err) {
      fill(this.estopMsg, `${overSocket ? "Sent over the run's connection; the server also said: " : "The emergency stop was refused: "}${err instanceof ApiError ? err.message : String(err)}`);
    }
  }

  private stopWatching(): void {
    this.unsubscribe?.();
    this.unsubscribe = null;
  }

  destroy(): void {
    this.stopWatching();
    this.estopBar.remove();
  }
}
