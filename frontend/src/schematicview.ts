// The plant you can see move: an SVG schematic of the run's plant beside its plot, drawn
// from one sample of the ring (the newest while live, the replay's position after) at most
// once per animation frame. Geometry in schematic.ts; this module only builds and updates
// the SVG, and says which sample it shows (data-k) and the values it drew.
import { FramePacer, h } from "./dom";
import type { PlantDetail, RunInfo } from "./protocol.gen";
import { beltView, DEG, fixed, growSpan, linkShape, pathD, symbol, toScreen } from "./schematic";
import type { SampleRing } from "./series";
import { display, fmt } from "./units";

const NS = "http://www.w3.org/2000/svg";
type Value = (channel: string) => number;

function svg(tag: string, attrs: Record<string, string | number> = {}, ...children: SVGElement[]): SVGElement {
  const el = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, String(v));
  el.append(...children);
  return el;
}

/** "rotate(a cx cy)" with a in degrees, clockwise on the screen. */
function turn(el: SVGElement, degrees: number, cx: number, cy: number): void {
  el.setAttribute("transform", `rotate(${Number.isFinite(degrees) ? degrees.toFixed(3) : 0} ${cx} ${cy})`);
}

/** One plant's drawing: its elements, and how a sample moves them. */
interface Drawing {
  title: string;
  parts: SVGElement[];
  update(v: Value): void;
}

/** Rotary flexible link, from above: the servo arm turns by θ (counter-clockwise), the link
 * bends so its tip sits α further on; the dashed line is the reference r for θ. */
function flexibleLink(): Drawing {
  const [cx, cy, L] = [120, 100, 86];
  const ref = svg("line", { class: "ref", x1: cx, y1: cy, x2: cx + L + 18, y2: cy });
  const link = svg("path", { class: "link" });
  const tip = svg("circle", { class: "mass", r: 5 });
  const arm = svg("g", { "data-testid": "schematic-arm", "data-channel": "theta" }, svg("rect", { class: "rigid", x: cx - 6, y: cy - 5, width: 26, height: 10, rx: 3 }), link, tip);
  const local = (alpha: number) => linkShape(alpha, L).map((p) => toScreen(p, cx, cy));
  return {
    title: "the servo arm turning by θ and the flexible link bending by α, seen from above",
    parts: [svg("circle", { class: "body", cx, cy, r: 24 }), ref, arm, svg("circle", { class: "hub", cx, cy, r: 7 })],
    update(v) {
      const pts = local(v("alpha") || 0);
      link.setAttribute("d", pathD(pts));
      tip.setAttribute("cx", pts[pts.length - 1].x.toFixed(2));
      tip.setAttribute("cy", pts[pts.length - 1].y.toFixed(2));
      turn(arm, -v("theta") * DEG, cx, cy);
      turn(ref, -v("r") * DEG, cx, cy);
    },
  };
}

/** Rotary double pendulum: the disc from above (its arm at α, the dashed line the reference
 * r for α), and the two pendulums from the side, at β₁ and β₂ from upright (absolute,
 * positive clockwise on the screen; β₂ = 180° hangs down). */
function doublePendulum(): Drawing {
  const [dx, dy, R] = [58, 100, 42];
  const [px, py] = [172, 100];
  const ref = svg("line", { class: "ref", x1: dx, y1: dy, x2: dx + R + 8, y2: dy });
  const arm = svg("g", { "data-testid": "schematic-arm", "data-channel": "alpha" }, svg("line", { class: "rod", x1: dx, y1: dy, x2: dx + R, y2: dy }), svg("circle", { class: "mass", cx: dx + R, cy: dy, r: 5 }));
  const pendulum = (length: number, channel: string) =>
    svg("g", { "data-testid": `schematic-${channel}`, "data-channel": channel }, svg("line", { class: "rod", x1: px, y1: py, x2: px, y2: py - length }), svg("circle", { class: "mass", cx: px, cy: py - length, r: 6 }));
  const p1 = pendulum(66, "beta1");
  const p2 = pendulum(50, "beta2");
  const caption = (x: number, text: string) => {
    const t = svg("text", { class: "caption", x, y: 194, "text-anchor": "middle" });
    t.textContent = text;
    return t;
  };
  return {
    title: "the disc turning by α seen from above, and the two pendulums swinging by β₁ and β₂ seen from the side",
    parts: [
      svg("circle", { class: "body", cx: dx, cy: dy, r: R }),
      ref,
      arm,
      svg("circle", { class: "hub", cx: dx, cy: dy, r: 5 }),
      svg("line", { class: "upright", x1: px, y1: py - 80, x2: px, y2: py + 80 }),
      p2,
      p1,
      svg("circle", { class: "hub", cx: px, cy: py, r: 5 }),
      caption(dx, "disc, from above"),
      caption(px, "pendulums, side"),
    ],
    update(v) {
      turn(arm, -v("alpha") * DEG, dx, dy);
      turn(ref, -v("r") * DEG, dx, dy);
      turn(p1, v("beta1") * DEG, px, py);
      turn(p2, v("beta2") * DEG, px, py);
    },
  };
}

/** Belt conveyor from the side: the load rides the belt to x, the belt's marks and the
 * drums move with it; the triangle is the reference r. The view's width (±span) grows when
 * the load would leave it. */
function beltConveyor(): Drawing {
  const [cx, cy, half, D, rd] = [120, 104, 90, 100, 16];
  const top = cy - rd;
  const belt = svg("path", { class: "belt", d: `M${cx - D} ${top}H${cx + D}A${rd} ${rd} 0 0 1 ${cx + D} ${cy + rd}H${cx - D}A${rd} ${rd} 0 0 1 ${cx - D} ${top}Z` });
  const drum = (x: number) => svg("g", { class: "drum" }, svg("circle", { class: "body", cx: x, cy, r: rd - 3 }), svg("line", { class: "rod", x1: x, y1: cy, x2: x, y2: cy - rd + 4 }));
  const drums = [drum(cx - D), drum(cx + D)];
  const load = svg("g", { "data-testid": "schematic-load", "data-channel": "x" }, svg("rect", { class: "load", x: cx - 14, y: top - 24, width: 28, height: 22, rx: 3 }));
  const target = svg("path", { class: "target", d: `M${cx} ${top - 28}l-6 -10h12z` });
  const scale = svg("text", { class: "caption", x: cx, y: 180, "text-anchor": "middle" });
  let span = 0.1;
  return {
    title: "the belt and its load moving to the position x, seen from the side",
    parts: [belt, ...drums, target, load, svg("line", { class: "upright", x1: cx, y1: cy + rd + 6, x2: cx, y2: cy + rd + 14 }), scale],
    update(v) {
      const x = v("x") || 0;
      const r = v("r") || 0;
      const wider = growSpan(growSpan(span, x), r);
      if (wider !== span || !scale.textContent) scale.textContent = `view ±${fmt(wider)} m`;
      span = wider;
      const b = beltView(x, r, span, half, rd);
      load.setAttribute("transform", `translate(${b.load.toFixed(2)} 0)`);
      target.setAttribute("transform", `translate(${b.target.toFixed(2)} 0)`);
      belt.setAttribute("stroke-dashoffset", b.dash.toFixed(2));
      drums.forEach((d, i) => turn(d, b.drum, cx + (i ? D : -D), cy));
    },
  };
}

const DRAWINGS: Record<string, () => Drawing> = {
  flexible_link: flexibleLink,
  double_pendulum: doublePendulum,
  belt_conveyor: beltConveyor,
};

export class PlantSchematic {
  /** null for a plant without a drawing */
  readonly root: HTMLElement | null = null;
  private readonly drawing: Drawing | null = null;
  private readonly svgEl: SVGElement | null = null;
  private readonly readout = h("dl.readout", { "data-testid": "sample-readout" });
  private readonly cells = new Map<string, HTMLElement>();
  private readonly timeEl = h("dd", { "data-channel": "t" });
  private readonly channels: { name: string; scale: number; unit: string }[] = [];
  private readonly ts: number;
  private k = -1;
  private readonly pacer = new FramePacer(() => this.draw());

  constructor(
    plant: PlantDetail,
    run: RunInfo,
    private readonly ring: SampleRing,
  ) {
    this.ts = run.Ts;
    const make = DRAWINGS[plant.id];
    if (!make) return;
    this.drawing = make();
    this.svgEl = svg("svg", { viewBox: "0 0 240 200", role: "img", "aria-label": `Animated schematic: ${this.drawing.title}` }, ...this.drawing.parts);
    const have = new Map(run.channels.map((c) => [c.name, c.unit]));
    const label = (name: string) => plant.outputs.find((o) => o.name === name)?.label ?? (name === "r" ? "reference r" : name === "u" ? "control u" : name);
    this.readout.append(h("dt", { title: "time" }, "t"), this.timeEl);
    for (const name of ["r", ...plant.outputs.map((o) => o.name), "u"]) {
      if (!have.has(name)) continue;
      const d = display(have.get(name)!);
      const dd = h("dd", { "data-channel": name });
      this.channels.push({ name, scale: d.scale, unit: d.unit });
      this.cells.set(name, dd);
      this.readout.append(h("dt", { title: label(name) }, symbol(label(name)) ?? name), dd);
    }
    this.root = h("figure.schematic", { "data-testid": "schematic", "data-plant": plant.id });
    this.root.append(this.svgEl, h("figcaption", this.readout));
  }

  /** Show sample k at the next animation frame at least frameInterval() after the last
   * draw, in step with the live plot's (many calls, one draw: the newest k). */
  show(k: number): void {
    this.k = k;
    if (this.drawing) this.pacer.ask();
  }

  private draw(): void {
    const k = this.k;
    if (!this.drawing || !this.svgEl || k < this.ring.start || k >= this.ring.end) return;
    const ring = this.ring;
    const value = (name: string) => (name in ring.data ? ring.at(name, k) : NaN);
    this.drawing.update(value);
    this.svgEl.setAttribute("data-k", String(k));
    this.readout.dataset.k = String(k);
    this.timeEl.textContent = `${(k * this.ts).toFixed(3)} s`;
    for (const c of this.channels) {
      const v = value(c.name) * c.scale;
      const cell = this.cells.get(c.name)!;
      cell.textContent = `${fixed(v)}${c.unit === "°" ? "°" : ` ${c.unit}`}`;
      cell.dataset.value = String(v); // as shown (°, mm, V), unrounded
    }
    this.root?.dispatchEvent(new Event("elab:schematic")); // for tests/bench/liveplot.py
  }

  destroy(): void {
    this.pacer.cancel();
  }
}
