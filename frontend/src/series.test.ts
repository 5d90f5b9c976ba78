import { describe, expect, it } from "vitest";
import { decimate, SampleRing } from "./series";

function ramp(k0: number, n: number, f: (k: number) => number = (k) => k): Float32Array {
  return Float32Array.from({ length: n }, (_, i) => f(k0 + i));
}

describe("SampleRing", () => {
  it("keeps the last `capacity` samples across wrap-around, in any chunking", () => {
    const ring = new SampleRing(["y"], 7);
    let k = 0;
    for (const n of [3, 1, 5, 2, 9, 4]) {
      ring.push(k, n, { y: ramp(k, n) });
      k += n;
    }
    expect(ring.end).toBe(24);
    expect(ring.size).toBe(7);
    expect(Array.from({ length: 7 }, (_, i) => ring.at("y", ring.start + i))).toEqual([17, 18, 19, 20, 21, 22, 23]);
  });

  it("restarts when samples do not follow on", () => {
    const ring = new SampleRing(["y"], 10);
    ring.push(0, 4, { y: ramp(0, 4) });
    ring.push(100, 2, { y: ramp(100, 2) });
    expect([ring.start, ring.end, ring.at("y", 100)]).toEqual([100, 102, 100]);
  });

  it("drops the samples past a run's recording", () => {
    const ring = new SampleRing(["y"], 10);
    ring.push(0, 25, { y: ramp(0, 25) });
    ring.truncate(22);
    expect([ring.start, ring.end, ring.at("y", 21)]).toEqual([15, 22, 21]);
    ring.truncate(30); // past the end: nothing to drop
    expect(ring.end).toBe(22);
    ring.truncate(5); // before the samples held: none stays
    expect([ring.size, ring.end]).toEqual([0, 5]);
  });

  it("refuses a capacity below one", () => {
    expect(() => new SampleRing(["y"], 0)).toThrow(/capacity/);
  });
});

describe("decimate", () => {
  const ring = new SampleRing(["y"], 100_000);
  const f = (k: number) => Math.sin(k / 300) + (k === 12_345 ? 5 : 0) - (k === 54_321 ? 7 : 0);
  ring.push(0, 100_000, { y: ramp(0, 100_000, f) });

  it("returns short spans whole", () => {
    const d = decimate(ring, "y", 10, 60, 100);
    expect(d.length).toBe(50);
    expect(Array.from(d.k)).toEqual(Array.from({ length: 50 }, (_, i) => 10 + i));
  });

  it("keeps every column's extremes, spikes included, with at most two points per column", () => {
    const d = decimate(ring, "y", 0, 100_000, 500);
    expect(d.length).toBeLessThanOrEqual(1000);
    const ys = Array.from(d.y);
    expect(Math.max(...ys)).toBeCloseTo(Math.fround(f(12_345)), 5);
    expect(Math.min(...ys)).toBeCloseTo(Math.fround(f(54_321)), 5);
    const ks = Array.from(d.k);
    expect(ks).toEqual([...ks].sort((a, b) => a - b)); // in time order
    // every column's min and max of the raw data appear
    for (let c = 0; c < 500; c += 37) {
      const a = Math.floor((c * 100_000) / 500);
      const b = Math.floor(((c + 1) * 100_000) / 500);
      let lo = Infinity;
      let hi = -Infinity;
      for (let k = a; k < b; k++) {
        lo = Math.min(lo, Math.fround(f(k)));
        hi = Math.max(hi, Math.fround(f(k)));
      }
      const inCol = ys.filter((_, i) => ks[i] >= a && ks[i] < b);
      expect(Math.min(...inCol)).toBe(lo);
      expect(Math.max(...inCol)).toBe(hi);
    }
  });

  it("clips the span to what the ring holds and skips NaN-only columns", () => {
    const r = new SampleRing(["y"], 10);
    r.push(0, 10, { y: new Float32Array(10).fill(NaN) });
    expect(decimate(r, "y", -5, 50, 2).length).toBe(0);
    expect(decimate(ring, "y", 99_990, 200_000, 100).length).toBe(10);
  });
});
