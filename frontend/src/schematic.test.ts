import { describe, expect, it } from "vitest";
import { beltView, DEG, fixed, growSpan, linkShape, niceSpan, pathD, pendulumEnd, polar, rotate, symbol, toScreen } from "./schematic";

const angle = (p: { x: number; y: number }) => Math.atan2(p.y, p.x);
const dist = (p: { x: number; y: number }) => Math.hypot(p.x, p.y);

describe("flexible link", () => {
  it("is straight along the arm when alpha = 0", () => {
    const pts = linkShape(0, 80);
    expect(pts).toHaveLength(13);
    for (const p of pts) expect(p.y).toBe(0);
    expect(pts[12].x).toBeCloseTo(80, 12);
  });

  it.each([0.05, -0.2, 0.5])("puts the tip at the deflection angle %f seen from the hub, at the link's length", (alpha) => {
    const tip = linkShape(alpha, 80).at(-1)!;
    expect(angle(tip)).toBeCloseTo(alpha, 12);
    expect(dist(tip)).toBeCloseTo(80, 10);
  });

  it("leaves the hub along the arm (a cantilever: no slope at the clamp)", () => {
    const [p0, p1] = linkShape(0.3, 80, 100);
    expect(p0).toEqual({ x: 0, y: 0 });
    expect(Math.abs(p1.y / p1.x)).toBeLessThan(0.02);
  });

  it("turns with the servo: the tip at theta + alpha", () => {
    const tip = rotate(linkShape(0.1, 80), 0.7).at(-1)!;
    expect(angle(tip)).toBeCloseTo(0.8, 12);
    expect(dist(tip)).toBeCloseTo(80, 10);
  });
});

describe("pendulums", () => {
  it("point up at 0, hang down at 180°, swing towards +x for positive angles", () => {
    expect(pendulumEnd(0, 50).y).toBeCloseTo(50, 12);
    expect(pendulumEnd(Math.PI, 50).y).toBeCloseTo(-50, 12);
    expect(pendulumEnd(Math.PI, 50).x).toBeCloseTo(0, 12);
    expect(pendulumEnd(0.1, 50).x).toBeGreaterThan(0);
    expect(pendulumEnd(Math.PI + 0.1, 50).x).toBeLessThan(0); // past hanging: back towards −x
    expect(dist(pendulumEnd(0.37, 50))).toBeCloseTo(50, 12);
  });
});

describe("screen coordinates", () => {
  it("flip y about the centre", () => {
    expect(toScreen({ x: 3, y: 4 }, 100, 100)).toEqual({ x: 103, y: 96 });
    expect(toScreen(polar(Math.PI / 2, 10), 0, 0).y).toBeCloseTo(-10, 12); // up is −y
    expect(pathD([{ x: 1, y: 2 }, { x: 3.14159, y: 4 }])).toBe("M1.00 2.00L3.14 4.00");
  });
});

describe("belt", () => {
  it("picks 1-2-5 half-widths that only grow", () => {
    expect(niceSpan(0.55)).toBe(1);
    expect(niceSpan(0.12)).toBeCloseTo(0.2, 15);
    expect(niceSpan(3)).toBe(5);
    expect(niceSpan(0.5)).toBe(0.5);
    expect(niceSpan(0)).toBe(1);
    expect(growSpan(1, 0.7)).toBe(1);
    expect(growSpan(1, -1.3)).toBe(2);
    expect(growSpan(0.5, 0.5)).toBe(1); // the load at the view's edge: wider
  });

  it("moves the load, the marks and the drums together with x", () => {
    const v = beltView(0.25, 0.5, 1, 80, 16);
    expect(v.load).toBe(20);
    expect(v.target).toBe(40);
    expect(v.dash).toBe(-20);
    expect(v.drum).toBeCloseTo((20 / 16) * DEG, 12); // the drum's rim travels with the belt
    expect(beltView(0, 0, 1, 80, 16)).toEqual({ load: 0, target: 0, dash: -0, drum: 0 });
  });
});

describe("readout", () => {
  it("names a channel by its symbol", () => {
    expect(symbol("servo angle θ")).toBe("θ");
    expect(symbol("pendulum 1 angle β₁ from upright")).toBe("β₁");
    expect(symbol("belt position x")).toBe("x");
    expect(symbol("reference r")).toBe("r");
    expect(symbol("something long")).toBeNull();
  });

  it("shows fixed decimals without a negative zero", () => {
    expect(fixed(-29.984)).toBe("-29.98");
    expect(fixed(-0.0004)).toBe("0.00");
    expect(fixed(180.04)).toBe("180.0");
    expect(fixed(NaN)).toBe("—");
  });
});
