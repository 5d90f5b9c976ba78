// A step response on the analysis page: outputs of very different size on separate axes
// (the pendulum's α moves a radian while β₁ and β₂ move a ten-thousandth of it), and a
// response the server cut where it left the plant's range says so.
import { fill, h } from "../dom";
import { channelColor, chart, purge, type Series } from "../plot";
import type { PlantDetail, StepOut } from "../protocol.gen";
import { display, fmt } from "../units";
import { downloadButton } from "./common";

/** Outputs share an axis while the largest peak is at most this many times the smallest. */
export const RANGE_RATIO = 10;

/** Output indices grouped (in order) so that within a group no peak |y| exceeds another by
 * more than `ratio`; an output that does not move (peak 0) joins the first group. */
export function groupByRange(peaks: number[], ratio = RANGE_RATIO): number[][] {
  const groups: number[][] = [];
  const still: number[] = [];
  for (const [i, p] of peaks.entries()) {
    if (!(p > 0)) {
      still.push(i);
      continue;
    }
    const fits = groups.find((g) => g.every((j) => Math.max(p, peaks[j]) <= ratio * Math.min(p, peaks[j])));
    if (fits) fits.push(i);
    else groups.push([i]);
  }
  if (!groups.length) return still.length ? [still] : [];
  groups[0].push(...still);
  groups[0].sort((a, b) => a - b);
  return groups;
}

export class StepPlot {
  readonly root: HTMLElement;
  private charts: HTMLElement[] = [];

  constructor(
    readonly plant: PlantDetail,
    /** file name of its data download, and its test id */
    readonly name: string,
  ) {
    this.root = h("div.step-plot", { "data-testid": name });
  }

  show(s: StepOut): void {
    this.destroy();
    const p = this.plant;
    const outputs = Object.entries(s.outputs).map(([name, y]) => {
      const out = p.outputs.find((o) => o.name === name);
      const d = display(out?.unit ?? "");
      const shown = y.map((v) => v * d.scale);
      // the same name and colour as on the live plot
      return { name, unit: out?.unit ?? "", label: out?.label ?? name, axisLabel: `${out?.label ?? name} (${d.unit})`, y: shown, peak: Math.max(0, ...shown.map(Math.abs)) };
    });
    const groups = groupByRange(outputs.map((o) => o.peak));
    this.charts = groups.map((_, i) => h("div.chart", { "data-testid": `${this.name}-axes-${i}` }));
    fill(this.root, ...this.charts, this.cutNote(s), downloadButton(`${this.name}.csv`, ["t (s)", ...outputs.map((o) => `${o.name} (${o.unit})`), "u (V)"], [s.t, ...Object.values(s.outputs), s.u]));
    groups.forEach((g, i) => {
      const names = this.plant.outputs.map((o) => o.name);
      const series: Series[] = g.map((j) => ({ x: s.t, y: outputs[j].y, name: outputs[j].label, axis: 1, color: channelColor(outputs[j].name, names) }));
      const title = g.map((j) => outputs[j].axisLabel).join(", ");
      if (i === 0) chart(this.charts[i], [...series, { x: s.t, y: s.u, name: "control u", axis: 2, color: channelColor("u", names) }], { xTitle: "time t (s)", yTitles: [title, "u (V)"] });
      else chart(this.charts[i], series, { xTitle: "time t (s)", yTitles: [title], height: 240 });
    });
  }

  private cutNote(s: StepOut): HTMLElement | null {
    const c = s.cut;
    if (!c) return null;
    const out = this.plant.outputs.find((o) => o.name === c.output);
    const d = display(out?.unit ?? "");
    const range = `${fmt(c.low * d.scale)} … ${fmt(c.high * d.scale)}${d.unit === "°" ? "°" : ` ${d.unit}`}`;
    return h(
      "p.note.cut",
      { "data-testid": `${this.name}-cut` },
      `${s.loop === "open" ? "The open loop" : "The loop"} is ${s.verdict}: ${out?.label ?? c.output} leaves ${range}, where the linear model holds, at t = ${fmt(c.t)} s. The response is cut there.`,
    );
  }

  destroy(): void {
    for (const c of this.charts) purge(c);
    this.charts = [];
  }
}
