// A finished run played back from its recording: play, pause, speed and a scrubber over its
// samples. The controls only keep the position; whoever owns them draws it (the plot up to
// that sample, the schematic at it).
import { h } from "./dom";

export const SPEEDS = [0.5, 1, 2, 5];

/**
 * The sample a replay shows at `now` (ms): it left sample `fromK` at `since` (ms) and runs at
 * `speed` × real time with sample time `Ts` (s); it stops at `last`.
 */
export function replayPosition(fromK: number, since: number, now: number, speed: number, Ts: number, last: number): number {
  return Math.min(last, fromK + Math.floor(((now - since) / 1000) * (speed / Ts)));
}

export class ReplayControls {
  readonly root: HTMLElement;
  private readonly playBtn: HTMLButtonElement;
  private readonly speedSel: HTMLSelectElement;
  private readonly scrubber: HTMLInputElement;
  private readonly timeEl = h("span.replay-time");
  private position: number;
  private playing = false;
  private fromK = 0;
  private since = 0;
  private frame = 0;

  constructor(
    private first: number,
    private last: number,
    private readonly Ts: number,
    /** the position moved (played, scrubbed): draw sample k */
    private readonly onPosition: (k: number) => void,
  ) {
    this.position = last;
    this.playBtn = h("button", { type: "button", "data-testid": "replay-play", onclick: () => (this.playing ? this.pause() : this.play()) }, "▶ Play");
    this.speedSel = h(
      "select",
      { "aria-label": "replay speed", "data-testid": "replay-speed", onchange: () => this.reanchor() },
      ...SPEEDS.map((s) => h("option", { value: String(s) }, `${s}×`)),
    );
    this.speedSel.value = "1";
    this.scrubber = h("input", { type: "range", min: first, max: last, step: 1, value: last, "aria-label": "replay position (sample)", "data-testid": "replay-position", oninput: () => this.seek(Number(this.scrubber.value)) });
    this.root = h("div.replay", { "data-testid": "replay" }, h("span.replay-label", "Replay"), this.playBtn, h("label.inline", "Speed ", this.speedSel), this.scrubber, this.timeEl);
    this.showTime();
  }

  get k(): number {
    return this.position;
  }

  get isPlaying(): boolean {
    return this.playing;
  }

  /** The recording now holds samples first … last. */
  setRange(first: number, last: number): void {
    this.first = first;
    this.last = last;
    this.scrubber.min = String(first);
    this.scrubber.max = String(last);
    this.seek(Math.min(Math.max(this.position, first), last));
  }

  play(): void {
    if (this.position >= this.last) this.seek(this.first); // from the start again
    this.playing = true;
    this.playBtn.textContent = "❚❚ Pause";
    this.playBtn.setAttribute("aria-pressed", "true");
    this.reanchor();
    const step = (now: number) => {
      const k = replayPosition(this.fromK, this.since, now, this.speed, this.Ts, this.last);
      if (k !== this.position) this.moveTo(k);
      if (k >= this.last) return this.pause();
      this.frame = requestAnimationFrame(step);
    };
    cancelAnimationFrame(this.frame);
    this.frame = requestAnimationFrame(step);
  }

  pause(): void {
    this.playing = false;
    cancelAnimationFrame(this.frame);
    this.frame = 0;
    this.playBtn.textContent = "▶ Play";
    this.playBtn.setAttribute("aria-pressed", "false");
  }

  /** Jump to sample k (playing goes on from there). */
  seek(k: number): void {
    this.moveTo(Math.min(Math.max(Math.round(k), this.first), this.last));
    this.reanchor();
  }

  destroy(): void {
    this.pause();
  }

  private get speed(): number {
    return Number(this.speedSel.value) || 1;
  }

  private reanchor(): void {
    this.fromK = this.position;
    this.since = performance.now();
  }

  private moveTo(k: number): void {
    this.position = k;
    this.scrubber.value = String(k);
    this.showTime();
    this.onPosition(k);
  }

  private showTime(): void {
    this.timeEl.textContent = `t = ${(this.position * this.Ts).toFixed(2)} s of ${(this.last * this.Ts).toFixed(2)} s`;
  }
}
