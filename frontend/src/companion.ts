// A second run drawn over a RunPanel's plot (dotted), e.g. the plant's predefined controller
// under the same reference as the run being tried. It streams into a ring of its own, and
// its pause, resume and stop follow the panel's run so the two stay side by side.
import { ENDED } from "./access";
import { api, ApiError } from "./api";
import { fill, h } from "./dom";
import type { LiveTrace } from "./plot";
import type { PlantDetail, RunInfo } from "./protocol.gen";
import { SampleRing } from "./series";
import { RunStream } from "./stream";
import { display, fmt } from "./units";

export class CompanionRun {
  readonly ring: SampleRing;
  readonly root: HTMLElement;
  state: string;
  private readonly stream: RunStream;
  private readonly statusEl = h("span.badge");
  private readonly progressEl = h("span.companion-progress");
  private readonly messageEl = h("span.error", { role: "alert" });
  /** commands to this run, one after another (a pause is answered before a resume is sent) */
  private queue: Promise<void> = Promise.resolve();

  constructor(
    public run: RunInfo,
    /** what the run is, e.g. "the predefined controller" */
    readonly label: string,
    capacity: number,
    onSamples: () => void,
  ) {
    this.state = run.status;
    this.ring = new SampleRing(run.channels.map((c) => c.name), capacity);
    this.root = h(
      "p.companion",
      { "data-companion": run.id, "data-testid": "companion" },
      "Dotted: ",
      label,
      ", run ",
      h("a", { href: `/runs/${run.id}`, "data-link": true, class: "mono" }, run.id),
      " ",
      this.statusEl,
      " ",
      this.progressEl,
      " ",
      this.messageEl,
    );
    this.stream = new RunStream(run.stream_url, {
      hello: (info) => {
        this.run = info;
        this.setState(info.status);
      },
      samples: (k0, n, cols) => {
        this.ring.push(k0, n, cols);
        this.progress();
        onSamples();
      },
      status: (s) => this.setState(s.state),
      error: (e) => fill(this.messageEl, e.message),
    }).open();
    this.setState(run.status);
  }

  get live(): boolean {
    return !ENDED.has(this.state);
  }

  /** Its outputs and control as dotted traces labelled with what it is. */
  traces(plant: PlantDetail, outputs: string[]): LiveTrace[] {
    const have = new Set(this.run.channels.map((c) => c.name));
    const traces: LiveTrace[] = plant.outputs
      .filter((o) => outputs.includes(o.name) && have.has(o.name))
      .map((o) => ({ channel: o.name, label: `${o.label}, ${this.label}`, axis: 1, scale: display(o.unit).scale, dash: "dot", ring: this.ring }));
    if (have.has("u")) traces.push({ channel: "u", label: `control u, ${this.label}`, axis: 2, scale: 1, dash: "dot", ring: this.ring });
    return traces;
  }

  /** Do to this run what was done to the one it is compared with: pause, resume, stop. */
  follow(state: string): Promise<void> {
    this.queue = this.queue.then(() => this.apply(state));
    return this.queue;
  }

  private async apply(state: string): Promise<void> {
    if (!this.live || !this.run.can_control) return;
    const id = this.run.id;
    const action = state === "paused" && this.state === "running" ? api.pause : state === "running" && this.state === "paused" ? api.resume : state === "stopped" ? api.stop : null;
    if (!action) return;
    try {
      this.setState((await action(id)).status);
    } catch (err) {
      if (err instanceof ApiError && err.status === 409) return; // it ended meanwhile
      fill(this.messageEl, err instanceof ApiError ? err.message : String(err));
    }
  }

  private setState(state: string): void {
    this.state = state;
    fill(this.statusEl, state);
    this.statusEl.dataset.state = state;
  }

  private progress(): void {
    fill(this.progressEl, `t = ${fmt(this.ring.end * this.run.Ts)} s`);
    this.progressEl.dataset.samples = String(this.ring.end);
  }

  destroy(): void {
    this.stream.close();
  }
}
