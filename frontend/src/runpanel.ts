// A run as the user sees it: status, who controls it, the live plot beside the plant's
// animated schematic, controls and downloads; once the whole recording is in, a replay.
// Used by the experiment views (for the run they start) and the run page (spectators,
// replays). Pause, resume and stop are there only for whoever may use them.
import { controlLabel, ENDED, reasonTone } from "./access";
import { api, ApiError, dataUrl } from "./api";
import { CompanionRun } from "./companion";
import { computeText } from "./controllertext";
import { copyText, csv, FramePacer, fill, h, saveText } from "./dom";
import { identity } from "./identity";
import { type ChangeEntry, type ChangeLike, ParamLog } from "./paramlog";
import { channelColor, LivePlot, type LiveTrace } from "./plot";
import { PredictionView } from "./prediction";
import { outcomeItems } from "./outcome";
import type { ComputeTimes, OutcomeMark, PlantDetail, RunInfo } from "./protocol.gen";
import { ReplayControls } from "./replay";
import { RigRunBar } from "./rigrun";
import { PlantSchematic } from "./schematicview";
import { SampleRing } from "./series";
import { RunStream } from "./stream";
import { display, fmt } from "./units";

/** Samples kept per channel in the page (10 min at 1 kHz); older ones scroll out. */
const MAX_RING = 600_000;
const WINDOW_S = 10;

function ringCapacity(run: RunInfo): number {
  return Math.max(1, Math.min(run.n_planned || 1, MAX_RING));
}

export interface RunPanelOptions {
  /** outputs to plot (default: every output of the plant) */
  outputs?: string[];
  /** show pause / resume / stop (to those who may use them; default true) */
  controls?: boolean;
  onState?(state: string): void;
  /** a live parameter change arrived (the run page's table follows it) */
  onChange?(change: ChangeEntry): void;
  /** a step of the plant's lesson: its caption in the run's bar, and what the presenter's
   * key (→, Page Down, N) starts next while presenting (null: the last step) */
  lesson?: { caption: string; next: (() => void) | null };
  /** a Python controller's run: once it ends, fetch its record for the controller's
   * compute time per step (the record has it a moment after the end) */
  awaitCompute?: boolean;
}

/** The keys that start a lesson's next step while presenting (a presenter's clicker sends
 * Page Down). */
const NEXT_KEYS = new Set(["ArrowRight", "PageDown", "n", "N"]);

/** How often, and how long, an ended run's record is asked for its outcome and compute times. */
const END_POLL_MS = 300;
const END_POLL_TRIES = 40;

export class RunPanel {
  readonly root: HTMLElement;
  readonly ring: SampleRing;
  readonly plot: LivePlot;
  state: string;
  private readonly stream: RunStream;
  private readonly statusEl = h("span.badge");
  private readonly progressEl = h("span.progress");
  /** the progress line at the live plot's pace, not at every message (50 a second, each
   * a layout and a paint) */
  private readonly progressPacer = new FramePacer(() => this.progress());
  private readonly connEl = h("span.conn", { "aria-live": "polite" });
  private readonly messageEl = h("p.error", { role: "alert" });
  /** why a run was paused or stopped: what people do with runs, not a failure */
  private readonly noticeEl = h("p.notice", { "aria-live": "polite", "data-testid": "run-notice" });
  /** a Python controller's compute time per step over the run, once it ended */
  private readonly computeEl = h("p.compute", { "data-testid": "run-compute-time", hidden: true });
  /** how the run went beyond its state (saturated, ran away…), once it ended */
  private readonly outcomeEl = h("ul.outcome", { "data-testid": "run-outcome", role: "status", hidden: true });
  private endAsked = false;
  /** the run alone on the screen, the plot as large as it goes (a projector); Esc leaves */
  private readonly presentButton = h("button.present", { type: "button", "data-testid": "present", "aria-pressed": "false", onclick: () => this.present(!this.root.classList.contains("presenting")) }, "Present");
  private readonly onKey = (ev: KeyboardEvent) => {
    if (!this.root.classList.contains("presenting")) return;
    if (ev.key === "Escape") this.present(false);
    const next = this.options.lesson?.next;
    if (next && NEXT_KEYS.has(ev.key) && !ev.repeat) {
      ev.preventDefault();
      document.removeEventListener("keydown", this.onKey); // one key, one step
      next();
    }
  };
  private closed = false;
  private readonly demoSlot = h("span.group");
  private readonly buttons: Record<"pause" | "resume" | "stop", HTMLButtonElement>;
  private readonly presentStop: HTMLButtonElement;
  private readonly windowSel: HTMLSelectElement;
  private readonly plotDiv = h("div.live-plot", { "data-testid": "live-plot", role: "figure", "aria-label": "live plot of the run" });
  private readonly schematic: PlantSchematic;
  /** the plot beside the plant's drawing */
  private readonly viewEl: HTMLElement;
  private replay: ReplayControls | null = null;
  private readonly replaySlot = h("div.replay-slot");
  /** the run's live parameter changes, each with what it altered */
  readonly changes: ParamLog;
  private outputs: string[];
  /** another run drawn over this one (overlay) */
  private companion: CompanionRun | null = null;
  /** a run on the rig: its emergency stop, loop latency and why it ended */
  private readonly rig: RigRunBar | null;
  /** the model's prediction drawn over the run, and run − prediction below (on request;
   * at once for a rig run, where the gap is the lesson) */
  private prediction: PredictionView | null = null;
  private predicting: Promise<void> | null = null;
  private readonly predictionBox: HTMLInputElement;
  private readonly predictionSlot = h("div.prediction-slot");

  constructor(
    public run: RunInfo,
    private readonly plant: PlantDetail,
    private readonly options: RunPanelOptions = {},
  ) {
    this.state = run.status;
    const names = run.channels.map((c) => c.name);
    this.ring = new SampleRing(names, ringCapacity(run));
    this.outputs = options.outputs?.length ? options.outputs : plant.outputs.map((o) => o.name);
    this.plot = new LivePlot(this.plotDiv, this.ring, this.traces(), {
      Ts: run.Ts,
      window: ENDED.has(run.status) ? null : WINDOW_S,
      yTitles: this.yTitles(plant),
    });
    this.schematic = new PlantSchematic(plant, run, this.ring);
    this.viewEl = h("div.run-view", this.plotDiv, this.schematic.root);
    this.changes = new ParamLog(run.request, plant);
    this.addChanges(run.param_changes);

    const btn = (label: string, action: () => Promise<RunInfo>) =>
      h("button", { type: "button", onclick: () => void this.command(action) }, label);
    this.buttons = {
      pause: btn("Pause", () => api.pause(run.id)),
      resume: btn("Resume", () => api.resume(run.id)),
      stop: btn("Stop", () => api.stop(run.id)),
    };
    // presenting folds the toolbar away, never the way to stop the run on the screen
    this.presentStop = h("button.present-stop", { type: "button", "data-testid": "present-stop", onclick: () => void this.command(() => api.stop(run.id)) }, "Stop");
    this.windowSel = h(
      "select",
      { "aria-label": "time window", onchange: () => this.setWindow(this.windowSel.value === "all" ? null : Number(this.windowSel.value)) },
      h("option", { value: "10" }, "last 10 s"),
      h("option", { value: "30" }, "last 30 s"),
      h("option", { value: "all" }, "whole run"),
    );
    this.windowSel.value = ENDED.has(run.status) ? "all" : "10";
    this.rig = run.mode === "rig" ? new RigRunBar(run, () => this.stream.send({ type: "estop" })) : null;
    this.predictionBox = h("input", { type: "checkbox", "data-testid": "show-prediction", onchange: () => void this.showPrediction(this.predictionBox.checked) });
    const share = `${location.origin}/runs/${run.id}`;
    this.root = h(
      "section.run-panel",
      { "data-run": run.id },
      h(
        "div.run-bar",
        h("span", "Run ", h("a", { href: `/runs/${run.id}`, "data-link": true, class: "mono" }, run.id)),
        this.statusEl,
        this.progressEl,
        this.connEl,
        h("span.owner", { "data-testid": "run-owner" }, controlLabel(run)),
        run.private ? h("span.badge.private", { title: "only its owner and instructors may see it" }, "private") : null,
        options.lesson ? h("span.lesson-caption", { "data-testid": "lesson-caption" }, options.lesson.caption, options.lesson.next ? h("small", " (→ next)") : h("small", " (the last step)")) : null,
        options.controls !== false && run.can_control ? this.presentStop : null,
        this.presentButton,
      ),
      this.rig?.root,
      this.viewEl,
      this.replaySlot,
      h(
        "div.toolbar",
        // a rig run cannot pause (a motor at 0 V holds no position): stop it
        options.controls !== false && run.can_control ? h("span.group", this.rig ? null : this.buttons.pause, this.rig ? null : this.buttons.resume, this.buttons.stop) : null,
        h("label.inline", "Window ", this.windowSel),
        h("label.inline", { title: "the same controller, reference and start on the model, and run − prediction" }, this.predictionBox, " Model prediction"),
        h(
          "span.group.downloads",
          "Download: ",
          h("a", { href: dataUrl(run, "csv"), download: `${run.id}.csv`, "data-testid": "download-csv" }, "CSV"),
          h("a", { href: dataUrl(run, "json"), download: `${run.id}.json` }, "JSON"),
          h("a", { href: dataUrl(run, "mat"), download: `${run.id}.mat` }, "MATLAB .mat"),
          h("button", { type: "button", class: "link", onclick: () => this.savePlotData() }, "plot data"),
        ),
        h("button", { type: "button", class: "link", onclick: (ev: Event) => void copyText(share, ev.currentTarget as HTMLButtonElement, "Link copied"), title: share }, "Copy share link"),
        this.demoSlot,
      ),
      this.predictionSlot,
      this.computeEl,
      this.outcomeEl,
      this.noticeEl,
      this.messageEl,
    );
    this.stream = new RunStream(run.stream_url, {
      hello: (info) => {
        this.run = info;
        this.setState(info.status);
        this.addChanges(info.param_changes); // those made while the page was away
      },
      samples: (k0, n, cols) => {
        this.ring.push(k0, n, cols);
        this.progressPacer.ask();
        this.plot.dirty();
        if (this.prediction?.series.follow(this.ring)) this.prediction.plot.dirty();
        if (!this.replay) this.schematic.show(this.ring.end - 1);
      },
      status: (s) => {
        this.setState(s.state);
        this.setReason(s.state, s.error ?? null);
      },
      params: (p) => this.addChanges([p]),
      error: (e) => fill(this.messageEl, e.message),
      connection: (state, detail) => {
        fill(this.connEl, state === "open" ? "" : detail ?? state);
        if (state === "reconnecting") this.root.dataset.reconnects = String(Number(this.root.dataset.reconnects ?? 0) + 1);
      },
      complete: (n) => {
        if (n < this.ring.end) {
          this.ring.truncate(n); // streamed but never stored: not part of the run
          this.plot.dirty();
        }
        this.windowSel.value = "all"; // the whole recording is here: show it
        this.setWindow(null);
        if (this.prediction?.series.follow(this.ring)) this.prediction.plot.dirty();
        if (this.prediction) void this.prediction.refresh(this.run.id, n); // over all of it now
        this.progress();
        this.offerReplay();
        this.rig?.complete(this.column("latency"));
      },
    }, { fromSeq: this.firstSeq(run) }).open();
    this.setState(run.status);
    this.setReason(run.status, run.error);
    this.setCompute(run.compute);
    this.setOutcome(run.outcome ?? null);
    void this.offerPin();
    // the rig's gap to its model, and a design's run against the response it predicted:
    // the evidence is the point of both
    if (run.mode === "rig" || run.experiment === "design") {
      this.predictionBox.checked = true;
      void this.showPrediction(true);
    }
  }

  private setWindow(seconds: number | null): void {
    this.plot.setWindow(seconds);
    this.prediction?.plot.setWindow(seconds);
  }

  /** Draw the model's prediction over the run and run − prediction below it, or hide them. */
  private async showPrediction(on: boolean): Promise<void> {
    if (on && !this.prediction) {
      this.predicting ??= this.loadPrediction();
      await this.predicting;
    }
    const shown = on && this.prediction !== null;
    this.predictionSlot.hidden = !shown;
    this.plot.setTraces(this.traces());
    if (shown) this.prediction?.plot.dirty();
  }

  private async loadPrediction(): Promise<void> {
    fill(this.predictionSlot, h("p.note", "Asking the model for its prediction…"));
    try {
      const p = await api.prediction(this.run.id);
      if (this.closed) return;
      const view = new PredictionView(p, this.plant, this.run.channels.map((c) => c.name), this.outputs, this.windowSel.value === "all" ? null : Number(this.windowSel.value));
      view.series.follow(this.ring);
      this.prediction = view;
      fill(this.predictionSlot, view.root);
      if (!this.live) void view.refresh(this.run.id, this.run.n_samples);
    } catch (err) {
      this.predicting = null; // ask again on the next tick of the box
      this.predictionBox.checked = false;
      fill(this.predictionSlot, h("p.error", { role: "alert" }, `No prediction: ${err instanceof ApiError ? err.message : String(err)}`));
    }
  }

  /** Changes from the record or the stream: each new one gets its labelled mark. */
  private addChanges(changes: ChangeLike[]): void {
    const added = changes.map((c) => this.changes.add(c)).filter((e) => e !== null);
    if (!added.length) return;
    this.plot.setMarks(this.changes.entries.map((e) => ({ k: e.k, label: e.label, text: e.text })));
    for (const e of added) this.options.onChange?.(e);
  }

  /** The whole recording is in the page: play it back, the plot and the schematic
   * following the position (the plot draws the samples up to it). */
  private offerReplay(): void {
    if (this.replay || !this.ring.size) return;
    const last = this.ring.end - 1;
    this.replay = new ReplayControls(this.ring.start, last, this.run.Ts, (k) => {
      this.plot.setEnd(k >= last ? null : k + 1);
      this.prediction?.plot.setEnd(k >= last ? null : k + 1);
      this.schematic.show(k);
    });
    fill(this.replaySlot, this.replay.root);
  }

  get live(): boolean {
    return !ENDED.has(this.state);
  }

  /** Where a late joiner starts: the last window of a live run, all of an ended one. */
  private firstSeq(run: RunInfo): number {
    if (ENDED.has(run.status)) return 0;
    const back = Math.round(WINDOW_S / run.Ts);
    return Math.floor(Math.max(0, run.n_samples - back) / run.frame_samples);
  }

  /** This run's traces, then those of the run drawn over it. */
  private traces(): LiveTrace[] {
    const plant = this.plant;
    const chosen = this.outputs;
    const have = new Set(this.run.channels.map((c) => c.name));
    const unit = (name: string) => this.run.channels.find((c) => c.name === name)?.unit ?? "";
    const { axis } = outputAxes(plant);
    const traces: LiveTrace[] = [];
    if (have.has("r")) traces.push({ channel: "r", label: "reference r", axis: axis.get("r") ?? 1, scale: display(unit("r")).scale, dash: "dash" });
    for (const o of plant.outputs)
      if (chosen.includes(o.name) && have.has(o.name)) traces.push({ channel: o.name, label: o.label, axis: axis.get(o.name) ?? 1, scale: display(o.unit).scale });
    if (have.has("u")) traces.push({ channel: "u", label: "control u", axis: axis.get("u") ?? 2, scale: 1 });
    // the run drawn over this one: its channels on the same axes as this run's; every
    // signal in its own colour, the same on every plot of the plant
    const names = plant.outputs.map((o) => o.name);
    const predicted = this.prediction && this.predictionBox.checked ? this.prediction.traces(chosen) : [];
    const over = [...(this.companion?.traces(plant, chosen) ?? []), ...predicted].map((tr) => ({ ...tr, axis: axis.get(tr.channel) ?? tr.axis }));
    return [...traces, ...over].map((tr) => ({ ...tr, color: channelColor(tr.channel, names) }));
  }

  private yTitles(plant: PlantDetail): string[] {
    return outputAxes(plant).titles;
  }

  setOutputs(outputs: string[]): void {
    this.outputs = outputs.length ? outputs : this.plant.outputs.map((o) => o.name);
    this.plot.setTraces(this.traces());
  }

  /**
   * Draw `run` (same plant and Ts) over this one, dotted and labelled `label`, sample k over
   * sample k; it is paused, resumed and stopped with this run. The panel owns it from now.
   */
  overlay(run: RunInfo, label: string): CompanionRun {
    this.companion?.destroy();
    this.companion = new CompanionRun(run, label, ringCapacity(run), () => this.plot.dirty());
    this.viewEl.before(this.companion.root); // above the plot and drawing, not in their grid
    this.plot.setTraces(this.traces());
    return this.companion;
  }

  get overlaid(): CompanionRun | null {
    return this.companion;
  }

  private setState(state: string): void {
    if (state !== this.state) void this.companion?.follow(state);
    this.state = state;
    fill(this.statusEl, state);
    this.statusEl.dataset.state = state;
    const ended = ENDED.has(state);
    this.buttons.pause.disabled = state !== "running";
    this.buttons.resume.disabled = state !== "paused";
    this.buttons.stop.disabled = ended;
    this.presentStop.disabled = ended;
    this.options.onState?.(state);
    this.rig?.follow(state);
    this.progress();
    if (ended && !this.endAsked && !this.hasEnd(this.run)) {
      this.endAsked = true;
      void this.fetchEnd();
    }
  }

  /** Whether a record holds what is written with a run's end: its outcome, and a Python
   * controller's compute times when they are awaited. */
  private hasEnd(info: RunInfo): boolean {
    return info.outcome !== null && info.outcome !== undefined && (!this.options.awaitCompute || !!info.compute);
  }

  /** The run alone on the screen (the plot filling it, the drawing over its top left
   * corner, where the oldest samples are, the controls folded away), or back in its page. */
  present(on: boolean): void {
    this.root.classList.toggle("presenting", on);
    this.presentButton.setAttribute("aria-pressed", String(on));
    fill(this.presentButton, on ? "Leave (Esc)" : "Present");
    if (on) document.addEventListener("keydown", this.onKey);
    else document.removeEventListener("keydown", this.onKey);
    this.plot.dirty();
  }

  /** How the run went beyond its state, each mark the server's sentence. */
  private setOutcome(marks: OutcomeMark[] | null): void {
    this.outcomeEl.hidden = !marks?.length;
    fill(this.outcomeEl, ...outcomeItems(marks ?? []));
  }

  /** A Python controller's compute time per step, and the round trip the run waited for. */
  private setCompute(c: ComputeTimes | null): void {
    this.computeEl.hidden = !c;
    fill(this.computeEl, c ? computeText(c) : null);
  }

  /** The ended run's record, asked until it has its outcome and compute times (written
   * with the end, a moment after the stream says it ended). A failure the stream did not
   * explain is shown as the record says it. */
  private async fetchEnd(): Promise<void> {
    for (let i = 0; i < END_POLL_TRIES && !this.closed; i++) {
      if (i) await new Promise((resolve) => setTimeout(resolve, END_POLL_MS));
      let info: RunInfo;
      try {
        info = await api.run(this.run.id);
      } catch {
        continue; // asked again: the run's plot and status stand without it
      }
      if (this.closed) return;
      if (ENDED.has(info.status) && info.error && !this.messageEl.textContent) this.setReason(info.status, info.error);
      if (info.compute) this.setCompute(info.compute);
      this.setOutcome(info.outcome ?? null);
      if (this.hasEnd(info)) {
        this.run = { ...this.run, compute: info.compute, outcome: info.outcome };
        return;
      }
    }
  }

  /** Why the run is in `state` (paused by someone, stopped, failed), from the server. */
  private setReason(state: string, reason: string | null): void {
    if (this.rig?.follow(state, reason)) return; // a rig run's end has its own banner
    const tone = reasonTone(state, reason);
    if (tone === "error") fill(this.messageEl, reason);
    else if (tone === "notice") fill(this.noticeEl, reason);
    else if (!ENDED.has(state)) fill(this.noticeEl); // resumed: the pause's reason is over
  }

  /** Instructors may pin any run they see as the class demo on the start page. */
  private async offerPin(): Promise<void> {
    const me = await identity.get().catch(() => null);
    if (me?.role !== "instructor") return;
    const pin = h("button", { type: "button", onclick: () => void this.pin() }, "Pin as class demo");
    fill(this.demoSlot, pin);
  }

  private async pin(): Promise<void> {
    fill(this.messageEl);
    try {
      await api.pinDemo(this.run.id);
      fill(this.demoSlot, h("span.note", { "data-testid": "pinned" }, "Pinned as the class demo"));
    } catch (err) {
      fill(this.messageEl, err instanceof ApiError ? err.message : String(err));
    }
  }

  private progress(): void {
    const t = this.ring.end * this.run.Ts;
    const total = this.run.n_planned * this.run.Ts;
    fill(this.progressEl, `t = ${t.toFixed(2)} s of ${fmt(total)} s · ${this.ring.end.toLocaleString("en")} samples`);
    this.progressEl.dataset.samples = String(this.ring.end);
  }

  private async command(action: () => Promise<RunInfo>): Promise<void> {
    fill(this.messageEl);
    try {
      const info = await action();
      this.setState(info.status);
    } catch (err) {
      fill(this.messageEl, err instanceof ApiError ? err.message : String(err));
    }
  }

  /** A channel's samples held in the page, oldest first (null: the run has no such channel). */
  private column(name: string): Float32Array | null {
    if (!this.run.channels.some((c) => c.name === name)) return null;
    const out = new Float32Array(this.ring.size);
    for (let i = 0; i < out.length; i++) out[i] = this.ring.at(name, this.ring.start + i);
    return out;
  }

  /** The samples held in the page (what the plot can show), as CSV in SI units. */
  private savePlotData(): void {
    const k0 = this.ring.start;
    const n = this.ring.size;
    const t = new Float64Array(n);
    for (let i = 0; i < n; i++) t[i] = (k0 + i) * this.run.Ts;
    // in the plot's units (degrees, mm): the numbers the plot shows; the recording's
    // downloads (CSV, JSON, .mat) stay in SI
    const cols = this.run.channels.map((c) => {
      const { scale } = display(c.unit);
      const out = new Float64Array(n);
      for (let i = 0; i < n; i++) out[i] = this.ring.at(c.name, k0 + i) * scale;
      return out;
    });
    const header = ["t (s)", ...this.run.channels.map((c) => `${c.name} (${display(c.unit).unit})`)];
    saveText(`${this.run.id}-plot.csv`, csv(header, [t, ...cols]));
  }

  destroy(): void {
    this.closed = true;
    this.progressPacer.cancel();
    document.removeEventListener("keydown", this.onKey);
    this.stream.close();
    this.replay?.destroy();
    this.schematic.destroy();
    this.companion?.destroy();
    this.rig?.destroy();
    this.prediction?.destroy();
    this.plot.destroy();
  }
}

/**
 * The live plot's axes for a plant: outputs that sit away from zero at the operating point
 * (the double pendulum's β₂ hangs at 180° while α and β₁ move about a degree) get axes of
 * their own, the others share the first with the reference; the control u is last.
 */
export function outputAxes(plant: PlantDetail): { axis: Map<string, number>; titles: string[] } {
  const offset = (i: number) => plant.C[i].reduce((sum, c, j) => sum + c * (plant.operating_point[j] ?? 0), 0);
  // an output away from 0 (β₂ about 180°), or one the linear model holds only in a narrow
  // range (a pendulum's half degree beside the disc's 45°), gets axes of its own
  const narrow = new Set((plant.initial_state_ranges as [string, number, number][]).map(([name]) => name));
  const alone = (i: number) => Math.abs(offset(i)) >= 1e-12 || narrow.has(plant.outputs[i].name);
  const shared = plant.outputs.filter((_, i) => !alone(i));
  const own = plant.outputs.filter((_, i) => alone(i));
  const symbol = (o: (typeof plant.outputs)[number]) => channelSymbol(o.label, o.name);
  const axis = new Map<string, number>();
  const units = (outs: typeof plant.outputs) => [...new Set(outs.map((o) => display(o.unit).unit))].join(", ");
  const titles: string[] = [];
  if (shared.length || !own.length) {
    titles.push(shared.length === plant.outputs.length ? `outputs (${units(shared)})` : `${shared.map(symbol).join(", ")} (${units(shared)})`);
    for (const o of shared) axis.set(o.name, 1);
  }
  for (const o of own) {
    titles.push(`${symbol(o)} (${display(o.unit).unit})`);
    axis.set(o.name, titles.length);
  }
  axis.set("r", axis.get(plant.reference_output) ?? 1);
  titles.push(`u (${plant.inputs[0]?.unit ?? "V"})`);
  axis.set("u", titles.length);
  return { axis, titles };
}

/** A channel's symbol as its legend writes it: the label's first word with a letter beyond
 * ASCII ("pendulum 1 angle β₁ from upright" → "β₁"), else its name ("x"). */
export function channelSymbol(label: string, name: string): string {
  return label.split(/\s+/).find((w) => /[^\x20-\x7e]/.test(w)) ?? name;
}
