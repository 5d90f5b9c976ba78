// The rig's status panel (the start page, the flexible link's page): online or not, an
// emulated rig said plainly, who holds it, the queue and the caller's place, the loop's
// latency; the emergency stop for the driver and instructors while a run is on it, and
// the instructor's take over, extend and clear. Nothing at all on a server without a rig.
import { api } from "../api";
import { fill, h } from "../dom";
import { identity } from "../identity";
import type { Me, RigQueueInfo } from "../protocol.gen";
import { clock, placeText, remaining, rigButtons, rigIdentity, rigSummary, type Role } from "../rig";
import { rigFeed, type RigFeedState } from "../rigfeed";
import { kindBadge } from "../rigrun";
import { errorText } from "./common";

/** s an instructor's Extend adds to the driver's slot */
export const EXTEND_S = 300;

/** A span counting down to `until` (the server's unix s); `Ticker.tick` updates it. */
export function countdown(until: number | null): HTMLElement {
  return h("span.countdown.mono", { "data-until": until ?? "" });
}

/** Once a second: every countdown under `root` shows the time left, from the last queue. */
export class Ticker {
  private readonly stop: () => void;
  private last: { q: RigQueueInfo; at: number } | null = null;

  constructor(private readonly root: HTMLElement) {
    const t = setInterval(() => this.tick(), 1000);
    this.stop = () => clearInterval(t);
  }

  seen(q: RigQueueInfo, at: number): void {
    this.last = { q, at };
    this.tick();
  }

  tick(): void {
    if (!this.last) return;
    for (const el of this.root.querySelectorAll<HTMLElement>("[data-until]")) {
      const until = Number(el.dataset.until);
      el.textContent = el.dataset.until ? clock(remaining(until, this.last.q, this.last.at, Date.now())) : "";
    }
  }

  destroy(): void {
    this.stop();
  }
}

/** The queue of a feed state (an error keeps the last one shown). */
export function queueOf(state: RigFeedState): { q: RigQueueInfo; at: number } | null {
  if (state.kind === "rig") return state;
  return state.kind === "error" ? state.last : null;
}

/** Run a queue operation: its answer goes to the feed, its refusal to `msg` (the server
 * says what to do: "… arm it before starting", "only an instructor may …"). */
export async function queueOp(op: () => Promise<RigQueueInfo>, msg: HTMLElement, button?: HTMLButtonElement): Promise<boolean> {
  fill(msg);
  if (button) button.disabled = true;
  try {
    rigFeed.set(await op());
    return true;
  } catch (err) {
    fill(msg, errorText(err));
    void rigFeed.refresh();
    return false;
  } finally {
    if (button) button.disabled = false;
  }
}

type PanelButton = "estop" | "takeover" | "extend" | "clear";

export class RigStatusPanel {
  readonly root: HTMLElement;
  private readonly kind = h("span");
  private readonly state = h("span.badge.rig-state", { "data-testid": "rig-state" });
  private readonly headline = h("span", { "data-testid": "rig-headline" });
  private readonly ident = h("p.muted.rig-identity", { "data-testid": "rig-identity" });
  private readonly details = h("p.rig-details", { "data-testid": "rig-details" });
  private readonly slot = h("p.rig-slot", { hidden: true }, "Slot ends in ", countdown(null));
  private readonly you = h("p.rig-you", { "data-testid": "rig-you", "aria-live": "polite" });
  private readonly msg = h("p.error", { role: "alert", "data-testid": "rig-error" });
  /** the poll failed: the status shown is the last one read */
  private readonly stale = h("p.notice", { "aria-live": "polite" });
  private readonly buttons: Record<PanelButton, HTMLButtonElement>;
  private readonly ticker: Ticker;
  private role: Role = "student";
  private last: RigQueueInfo | null = null;
  private readonly unsubscribe: (() => void)[];

  constructor(
    /** more to show below the status (the start page: where to run on the rig) */
    extra: HTMLElement | null = null,
  ) {
    const button = (label: string, action: (b: HTMLButtonElement) => void, cls = "") => {
      const b: HTMLButtonElement = h("button", { type: "button", class: cls, hidden: true, onclick: () => action(b) }, label);
      return b;
    };
    this.buttons = {
      estop: button("Emergency stop", (b) => void queueOp(api.estopRig, this.msg, b), "estop"),
      takeover: button("Take over", (b) => void this.takeOver(b)),
      extend: button(`Extend +${EXTEND_S / 60} min`, (b) => void queueOp(() => api.extendRig(EXTEND_S), this.msg, b)),
      clear: button("Clear queue", (b) => void this.clear(b)),
    };
    this.root = h(
      "section.panel.rig-status",
      { "data-testid": "rig-status", hidden: true, "aria-labelledby": "rig-status-h" },
      h("h2#rig-status-h", "Flexible-link rig ", this.kind),
      h("p.rig-headline", this.state, " ", this.headline),
      this.ident,
      this.details,
      this.slot,
      this.you,
      this.stale,
      h("div.toolbar.rig-actions", this.buttons.estop, this.buttons.takeover, this.buttons.extend, this.buttons.clear),
      this.msg,
      extra,
    );
    this.ticker = new Ticker(this.root);
    const setRole = (me: Me) => {
      this.role = me.role === "instructor" ? "instructor" : "student";
      if (this.last) this.update(this.last);
    };
    this.unsubscribe = [rigFeed.subscribe((s) => this.show(s)), identity.listen(setRole)];
    void identity.get().then(setRole, () => undefined); // unknown: a student's buttons
  }

  private show(s: RigFeedState): void {
    if (s.kind === "none") {
      this.root.hidden = true;
      return;
    }
    const got = queueOf(s);
    fill(this.stale, s.kind === "error" ? `The rig's status could not be read (${s.message}); asking again every ${rigFeed.every / 1000} s.` : null);
    if (!got) return;
    this.update(got.q);
    this.ticker.seen(got.q, got.at);
  }

  private update(q: RigQueueInfo): void {
    this.last = q;
    const sum = rigSummary(q);
    this.root.hidden = false;
    this.root.dataset.condition = sum.condition;
    fill(this.kind, kindBadge(q.rig.emulated));
    fill(this.state, { offline: "offline", out_of_service: "out of service", settling: "settling", in_use: "in use", free: "free" }[sum.condition]);
    this.state.dataset.condition = sum.condition;
    fill(this.headline, sum.headline);
    fill(this.ident, rigIdentity(q.rig));
    fill(this.details, sum.details.join(" · "));
    this.slot.hidden = q.slot_ends_at === null;
    (this.slot.querySelector("[data-until]") as HTMLElement).dataset.until = String(q.slot_ends_at ?? "");
    const you = placeText(q);
    fill(this.you, you);
    this.you.hidden = !you;
    const show = rigButtons(q, this.role);
    for (const [name, b] of Object.entries(this.buttons) as [PanelButton, HTMLButtonElement][]) b.hidden = !show[name];
  }

  private async takeOver(b: HTMLButtonElement): Promise<void> {
    const q = this.last;
    if (q?.driver && !confirm(`Take the rig over from ${q.driver}?${q.phase === "running" ? " Their run stops now." : ""} They wait first in line after you.`)) return;
    await queueOp(api.takeOverRig, this.msg, b);
  }

  private async clear(b: HTMLButtonElement): Promise<void> {
    if (!confirm(`Remove the ${this.last?.waiting ?? ""} waiting user(s) from the rig's queue? The driver keeps the rig.`)) return;
    await queueOp(api.clearRig, this.msg, b);
  }

  destroy(): void {
    for (const u of this.unsubscribe) u();
    this.ticker.destroy();
  }
}
