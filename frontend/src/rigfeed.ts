// The rig's queue, polled (GET /rig) every 2 s while some view on the page shows it and
// the tab is visible; every view showing it shares one poll. The answers of the queue's
// operations (join, arm, …) are the queue too and are told at once. A server without a rig
// (404) is told once and not asked again until a view subscribes anew.
import { api, ApiError } from "./api";
import type { RigQueueInfo } from "./protocol.gen";

export const RIG_POLL_MS = 2000;

export type RigFeedState =
  | { kind: "rig"; q: RigQueueInfo; at: number }
  /** this server has no rig */
  | { kind: "none" }
  /** the last poll failed; `last`: the queue before, if any */
  | { kind: "error"; message: string; last: { q: RigQueueInfo; at: number } | null };

export type RigListener = (state: RigFeedState) => void;

export interface FeedClock {
  now(): number;
  every(ms: number, fn: () => void): () => void;
  hidden(): boolean;
  onVisible(fn: () => void): () => void;
}

const pageClock: FeedClock = {
  now: () => Date.now(),
  every: (ms, fn) => {
    const t = setInterval(fn, ms);
    return () => clearInterval(t);
  },
  hidden: () => document.hidden,
  onVisible: (fn) => {
    const on = () => document.hidden || fn();
    document.addEventListener("visibilitychange", on);
    return () => document.removeEventListener("visibilitychange", on);
  },
};

export class RigFeed {
  private readonly listeners = new Set<RigListener>();
  private state: RigFeedState | null = null;
  private stop: (() => void)[] = [];
  private asking = false;
  private again = false;
  /** bumped with every state told: an answer that was overtaken is dropped */
  private version = 0;

  constructor(
    private readonly fetchQueue: () => Promise<RigQueueInfo> = api.rig,
    private readonly clock: FeedClock = pageClock,
    readonly every = RIG_POLL_MS,
  ) {}

  /** Called with the queue now (if known) and every change from now on; the returned
   * function unsubscribes, and the poll stops with the last subscriber. */
  subscribe(fn: RigListener): () => void {
    this.listeners.add(fn);
    if (this.state) fn(this.state);
    if (this.listeners.size === 1) this.begin();
    return () => {
      this.listeners.delete(fn);
      if (!this.listeners.size) this.end();
    };
  }

  /** Ask now (after an operation whose answer is not the queue, e.g. a run started). */
  async refresh(): Promise<void> {
    if (this.state?.kind === "none") return;
    if (this.asking) {
      this.again = true; // the answer on its way may predate what made us ask
      return;
    }
    this.asking = true;
    const asked = this.version;
    try {
      const q = await this.fetchQueue();
      if (this.version === asked) this.tell({ kind: "rig", q, at: this.clock.now() });
    } catch (err) {
      if (err instanceof ApiError && err.status === 404) {
        // no rig on this server (GET /rig takes no input to be wrong about)
        this.tell({ kind: "none" });
        this.end();
        return;
      }
      const last = this.state?.kind === "rig" ? { q: this.state.q, at: this.state.at } : this.state?.kind === "error" ? this.state.last : null;
      this.tell({ kind: "error", message: err instanceof Error ? err.message : String(err), last });
    } finally {
      this.asking = false;
    }
    if (this.again && this.listeners.size) {
      this.again = false;
      await this.refresh();
    }
  }

  /** The answer of a queue operation: the queue now. */
  set(q: RigQueueInfo): void {
    this.tell({ kind: "rig", q, at: this.clock.now() });
  }

  get current(): RigFeedState | null {
    return this.state;
  }

  private begin(): void {
    if (this.state?.kind === "none") this.state = null; // a new view: ask again
    this.stop = [
      this.clock.every(this.every, () => this.clock.hidden() || void this.refresh()),
      this.clock.onVisible(() => void this.refresh()),
    ];
    void this.refresh();
  }

  private end(): void {
    for (const s of this.stop) s();
    this.stop = [];
  }

  private tell(state: RigFeedState): void {
    this.version += 1;
    this.state = state;
    for (const fn of [...this.listeners]) fn(state);
  }
}

/** The page's feed. */
export const rigFeed = new RigFeed();
