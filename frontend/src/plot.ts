// The only module that imports plotly.js: the live plot of a run and the static charts
// (Bode, step, poles). Views hand it typed arrays and titles, never plotly objects.
import Plotly from "plotly.js-basic-dist-min";
import { FramePacer } from "./dom";
import { decimate, type SampleRing } from "./series";

const COLORS = ["#2563eb", "#dc2626", "#059669", "#d97706", "#7c3aed", "#0891b2", "#be185d", "#4b5563"];

/** One colour per signal on every plot of a plant (issue 15: θ was blue live and red in the
 * step plot): the reference grey, the control amber, the outputs in the plant's order. */
const REFERENCE_COLOR = "#4b5563";
const CONTROL_COLOR = "#d97706";
const OUTPUT_COLORS = ["#2563eb", "#dc2626", "#059669", "#7c3aed", "#0891b2", "#be185d"];
export function channelColor(channel: string, outputs: readonly string[]): string | undefined {
  if (channel === "r") return REFERENCE_COLOR;
  if (channel === "u") return CONTROL_COLOR;
  const k = outputs.indexOf(channel);
  return k >= 0 ? OUTPUT_COLORS[k % OUTPUT_COLORS.length] : undefined;
}

function fontSize(): number {
  return document.body.classList.contains("classroom") ? 18 : 13;
}

function baseLayout(): Partial<Plotly.Layout> {
  return {
    font: { family: "system-ui, sans-serif", size: fontSize(), color: "#1f2937" },
    paper_bgcolor: "rgba(0,0,0,0)",
    plot_bgcolor: "#ffffff",
    margin: { l: 64, r: 16, t: 24, b: 48 },
    showlegend: true,
    legend: { orientation: "h", y: 1.02, yanchor: "bottom", x: 0 },
    hovermode: "x unified",
  };
}

const CONFIG: Partial<Plotly.Config> = { responsive: true, displaylogo: false, scrollZoom: false };

/**
 * A debugging and benchmark knob, exposed as `window.elab.plotSettings`: `decimate: false`
 * makes live plots draw every sample of their window (tests/bench/liveplot.py's peer).
 */
export const plotSettings = { decimate: true };

/**
 * The live plot draws at most every frameInterval() (dom.ts: 25 ms, 30 frames per second,
 * which looks smooth and leaves the main thread more than half its time, docs/benchmarks.md;
 * 200 ms where the reader asks for reduced motion). Samples arrive about 50 times a second;
 * none is lost by skipping a draw, the next one shows them.
 */

export interface LiveTrace {
  /** channel name in the ring */
  channel: string;
  label: string;
  /** which axes, 1 … n from the top: the outputs' (one or more), the control's last */
  axis: number;
  /** displayed = scale · value */
  scale: number;
  /** the signal's colour (channelColor); default: by position */
  color?: string;
  dash?: "solid" | "dash" | "dot";
  /** the ring holding the channel when it is not the plot's: another run drawn over this
   * one, sample k over sample k (same Ts) */
  ring?: SampleRing;
}

export interface PlotMark {
  /** the sample from which it holds */
  k: number;
  label: string;
  /** the whole sentence, shown when the label is hovered */
  text?: string;
}

export interface LivePlotOptions {
  Ts: number;
  /** rolling window in seconds; null shows everything the ring holds */
  window: number | null;
  /** one per axes, top to bottom: the outputs' (one or more), then the control's */
  yTitles: string[];
}

/** The vertical domains of n stacked axes: the last (the control) at the bottom, the
 * others sharing the upper part. */
function domains(n: number): [number, number][] {
  if (n <= 1) return [[0, 1]];
  const top: [number, number][] = [];
  const gap = 0.06;
  const each = (1 - 0.38 - gap * (n - 2)) / (n - 1);
  for (let i = 0; i < n - 1; i++) {
    const hi = 1 - i * (each + gap);
    top.push([Math.max(0.38, hi - each), hi]);
  }
  return [...top, [0, 0.28]];
}

const axisId = (i: number): string => (i === 1 ? "y" : `y${i}`);
const axisKey = (i: number): string => (i === 1 ? "yaxis" : `yaxis${i}`);

/**
 * A live plot of a run: every animation frame at most one redraw, of the window's samples
 * decimated to two points per pixel column per trace.
 */
export class LivePlot {
  /** draws at the pace of frameInterval(); cancelled when purged (plotly has nothing to
   * draw into then) */
  private readonly pacer = new FramePacer(() => this.draw());
  private marks: PlotMark[] = [];
  private end: number | null = null;
  private draws = 0;
  /** what the last full plot was made of; while it holds, draws take the fast path */
  private layoutKey = "";
  private yRanges: ([number, number] | null)[] = [];
  private readonly resize = new ResizeObserver(() => this.dirty());
  /** purged: a draw already asked for (an animation frame away) does nothing */
  private destroyed = false;

  constructor(
    readonly div: HTMLElement,
    private readonly ring: SampleRing,
    private traces: LiveTrace[],
    private options: LivePlotOptions,
  ) {
    this.resize.observe(div);
  }

  /** Redraw at the next animation frame that is at least frameInterval() after the last draw
   * (many calls, one draw). */
  dirty(): void {
    if (!this.destroyed) this.pacer.ask();
  }

  setWindow(seconds: number | null): void {
    this.options = { ...this.options, window: seconds };
    this.yRanges = [];
    this.dirty();
  }

  setTraces(traces: LiveTrace[]): void {
    this.traces = traces;
    this.dirty();
  }

  /** Live parameter changes, drawn as dotted vertical lines labelled with what changed. */
  setMarks(marks: PlotMark[]): void {
    this.marks = marks;
    this.dirty();
  }

  /** A replay's position: draw the samples before `end` only (null: all the ring holds).
   * The time axis then keeps the whole recording and the y ranges only grow, so the lines
   * move and the axes stand still. */
  setEnd(end: number | null): void {
    this.end = end;
    this.dirty();
  }

  get drawCount(): number {
    return this.draws;
  }

  draw(): void {
    if (this.destroyed) return;
    const { Ts, window } = this.options;
    const rings = [this.ring, ...this.traces.flatMap((tr) => (tr.ring ? [tr.ring] : []))];
    const held = Math.max(...rings.map((r) => r.end));
    const end = this.end === null ? held : Math.min(held, this.end);
    const start = Math.min(...rings.map((r) => r.start));
    const span = window === null ? end - start : Math.round(window / Ts);
    const k0 = Math.max(start, end - span);
    // min/max per 2-pixel column: ≤ 1 point per pixel per trace, drawn as SVG (no WebGL
    // needed, so it also runs in software-rendered browsers and on old projector PCs)
    const columns = plotSettings.decimate ? Math.max(50, Math.floor((this.div.clientWidth - 80) / 2)) : Infinity;
    const nAxes = this.options.yTitles.length;
    const bounds = Array.from({ length: nAxes }, () => new Bounds());
    const series = this.traces.map((tr) => {
      const d = decimate(tr.ring ?? this.ring, tr.channel, k0, end, columns);
      const x = new Float64Array(d.length);
      const y = new Float32Array(d.length);
      const b = bounds[tr.axis - 1];
      for (let j = 0; j < d.length; j++) {
        x[j] = d.k[j] * Ts;
        y[j] = d.y[j] * tr.scale;
        b.add(y[j]);
      }
      return { x: x as unknown as number[], y: y as unknown as number[] };
    });
    // the time axis moves in steps of a tenth of the window: between steps only the traces
    // are redrawn (ticks and grid cost more than the lines)
    const t1 = Math.max(end, 1) * Ts;
    const step = (window ?? 1) / 10;
    const right = window === null ? t1 : Math.max(window, Math.ceil(t1 / step) * step);
    const last = this.end === null ? t1 : Math.max(held, 1) * Ts; // a replay keeps the whole run
    const xRange = window === null ? [start * Ts, Math.max(last, start * Ts + 1)] : [right - window, right];
    const yRanges = bounds.map((b, i) => (this.yRanges[i] = b.range(this.yRanges[i] ?? null, this.end !== null)));
    this.draws++;
    // a full plot when anything but the data changed (plotly leaves empty traces out of the
    // legend, so the first draw with samples of each ring is a full one too)
    const shown = this.traces.map(({ ring, ...tr }) => ({ ...tr, overlay: ring !== undefined, empty: (ring ?? this.ring).end === 0 }));
    const key = JSON.stringify([shown, this.marks, this.options, this.end === null, this.div.clientWidth, this.div.clientHeight, fontSize()]);
    if (key === this.layoutKey) {
      // the fast path: new points and ranges, no full replot (axes, legend, shapes stay)
      void track(
        this.div,
        Plotly.animate(
          this.div,
          { data: series, traces: series.map((_, i) => i), layout: { xaxis: { range: xRange }, ...Object.fromEntries(yRanges.map((r, i) => [axisKey(i + 1), { range: r }])) } },
          { transition: { duration: 0 }, frame: { duration: 0, redraw: false }, mode: "immediate" },
        ),
      ).then(() => this.div.dispatchEvent(new Event("elab:draw")));
      return;
    }
    this.layoutKey = key;
    const data: Partial<Plotly.PlotData>[] = this.traces.map((tr, i) => ({
      type: "scatter" as const,
      mode: "lines" as const,
      name: tr.label,
      ...series[i],
      yaxis: axisId(tr.axis) as Plotly.AxisName,
      line: { color: this.color(i), width: 1.5, dash: tr.dash ?? "solid" },
    }));
    const layout: Partial<Plotly.Layout> = {
      ...baseLayout(),
      height: Math.max(320, this.div.clientHeight || 420),
      // the container's own width: plotly's autosize follows the window, not a container
      // that grows by itself (a run presented on the whole screen)
      width: this.div.clientWidth || undefined,
      xaxis: { title: { text: "time t (s)" }, range: xRange, showgrid: true, anchor: axisId(nAxes) as Plotly.XAxisName },
      ...Object.fromEntries(
        domains(nAxes).map((domain, i) => [axisKey(i + 1), { title: { text: this.options.yTitles[i] }, domain, anchor: "x", zeroline: true, range: yRanges[i] }]),
      ),
      shapes: this.marks.map(({ k }) => ({
        type: "line" as const,
        xref: "x" as const,
        yref: "paper" as const,
        x0: k * Ts,
        x1: k * Ts,
        y0: 0,
        y1: 1,
        line: { color: "#6b7280", dash: "dot" as const, width: 1 },
      })),
      // each change's label along its line, reading upwards from the top of the outputs' axes
      annotations: this.marks.map(({ k, label, text }) => ({
        x: k * Ts,
        hovertext: text ?? label,
        xref: "x" as const,
        y: 1,
        yref: "paper" as const,
        text: label,
        textangle: "-90",
        xanchor: "right" as const,
        yanchor: "top" as const,
        showarrow: false,
        font: { size: fontSize() - 2, color: "#374151" },
        bgcolor: "rgba(255,255,255,0.8)",
      })),
      uirevision: "live",
    };
    // a rolling window is redrawn many times a second: no hover, zoom or mode bar then (they
    // cost on every draw and a zoom would be undone by the next frame); the whole run is
    // interactive
    const config = window === null ? CONFIG : { ...CONFIG, displayModeBar: false };
    if (window !== null) Object.assign(layout, { hovermode: false, dragmode: false });
    void react(this.div, data as Plotly.Data[], layout, config).then(() => this.div.dispatchEvent(new Event("elab:draw")));
  }

  /** A trace's colour: a trace of another run takes the colour of this run's trace of the
   * same channel (θ solid and θ dotted, side by side). */
  private color(i: number): string {
    const tr = this.traces[i];
    if (tr.color) return tr.color;
    const same = tr.ring ? this.traces.findIndex((t) => !t.ring && t.channel === tr.channel) : -1;
    return COLORS[(same >= 0 ? same : i) % COLORS.length];
  }

  destroy(): void {
    this.destroyed = true;
    this.pacer.cancel();
    this.resize.disconnect();
    purge(this.div);
  }
}

/** The extent of a trace's values, and a y range that only moves when it must. */
class Bounds {
  lo = Infinity;
  hi = -Infinity;

  add(v: number): void {
    if (v < this.lo) this.lo = v;
    if (v > this.hi) this.hi = v;
  }

  /** Keep `current` while the data fill more than half of it and stay inside; else refit
   * with 8 % margins, so the axis neither jitters nor clips. `growOnly` (a replay): keep it
   * while the data stay inside, widen it when they leave. */
  range(current: [number, number] | null, growOnly = false): [number, number] {
    if (this.lo > this.hi) return current ?? [-1, 1];
    const span = Math.max(this.hi - this.lo, 1e-9 * Math.max(1, Math.abs(this.hi)));
    const pad = this.hi > this.lo ? 0.08 * span : Math.max(1, Math.abs(this.hi) * 0.1);
    if (current === null) return [this.lo - pad, this.hi + pad];
    const inside = this.lo >= current[0] && this.hi <= current[1];
    if (inside && (growOnly || span > 0.5 * (current[1] - current[0]))) return current;
    if (growOnly) return [Math.min(current[0], this.lo - pad), Math.max(current[1], this.hi + pad)];
    return [this.lo - pad, this.hi + pad];
  }
}

export interface Series {
  x: ArrayLike<number>;
  /** null: no value there (a gap in the line) */
  y: ArrayLike<number | null>;
  name: string;
  /** which y axis (1 upper, 2 lower when the chart has two) */
  axis?: 1 | 2;
  dash?: "solid" | "dash" | "dot";
  mode?: "lines" | "markers";
  /** the signal's colour (channelColor); default: by position */
  color?: string;
}

export interface ChartOptions {
  xTitle: string;
  yTitles: [string] | [string, string];
  logX?: boolean;
  height?: number;
  /** equal scales on both axes (pole maps) */
  square?: boolean;
}

/** A static chart: one or two stacked y axes sharing x. */
export function chart(div: HTMLElement, series: Series[], opts: ChartOptions): void {
  const two = opts.yTitles.length === 2;
  const data: Partial<Plotly.PlotData>[] = series.map((s, i) => ({
    type: "scatter",
    mode: s.mode ?? "lines",
    name: s.name,
    x: Array.from(s.x),
    y: Array.from(s.y),
    yaxis: s.axis === 2 ? "y2" : "y",
    line: { color: s.color ?? COLORS[i % COLORS.length], width: 1.8, dash: s.dash ?? "solid" },
    marker: { color: s.color ?? COLORS[i % COLORS.length], size: 9, symbol: "x" },
  }));
  const layout: Partial<Plotly.Layout> = {
    ...baseLayout(),
    height: opts.height ?? (two ? 460 : 340),
    xaxis: { title: { text: opts.xTitle }, type: opts.logX ? "log" : "linear", showgrid: true, zeroline: !opts.logX },
    yaxis: two
      ? { title: { text: opts.yTitles[0] }, domain: [0.55, 1] }
      : { title: { text: opts.yTitles[0] }, ...(opts.square ? { scaleanchor: "x", scaleratio: 1 } : {}) },
  };
  if (two) {
    layout.yaxis2 = { title: { text: opts.yTitles[1] }, domain: [0, 0.45], anchor: "x" };
    layout.xaxis = { ...layout.xaxis, anchor: "y2" };
  }
  void react(div, data, layout, CONFIG);
}

/** Each plot's draw in flight: plotly finishes a draw in later tasks, and a purge before
 * then fails in them ("reading '_plots'": a lesson's next step replaced its run's plot
 * mid-draw). */
const drawing = new WeakMap<HTMLElement, Promise<unknown>>();

function react(div: HTMLElement, data: Plotly.Data[], layout: Partial<Plotly.Layout>, config: Partial<Plotly.Config>): Promise<unknown> {
  return track(div, Plotly.react(div, data, layout, config));
}

/** A draw of `div` in flight (a react, or the live plot's animated step: plotly steps a
 * transition in animation frames, and one after a purge failed in drawOne). */
function track(div: HTMLElement, draw: Promise<unknown>): Promise<unknown> {
  const done = draw.catch(() => undefined);
  drawing.set(div, done);
  return done;
}

/** Empty a plot, once a draw in flight has finished. */
export function purge(div: HTMLElement): void {
  const pending = drawing.get(div);
  drawing.delete(div);
  if (pending) void pending.then(() => drawing.has(div) || Plotly.purge(div)); // unless drawn anew meanwhile
  else Plotly.purge(div);
}
