import { afterEach, describe, expect, it, vi } from "vitest";
import { cell, csv, FramePacer } from "./dom";

describe("csv", () => {
  it("writes clean decimals, not float noise (issue 15)", () => {
    expect(cell(6.9590000000000005)).toBe("6.959");
    expect(cell(0.1 + 0.2)).toBe("0.3");
    expect(cell(1e-20)).toBe("1e-20");
    expect(cell(-123456.789)).toBe("-123456.789");
    expect(csv(["t (s)", "y (rad)"], [[0, 0.001 * 6959], [1, null]])).toBe("t (s),y (rad)\n0,1\n6.959,\n");
  });
});

describe("FramePacer", () => {
  // animation frames run by hand: each callback gets the time given to run()
  let queue = new Map<number, FrameRequestCallback>();
  let next = 1;
  const run = (now: number) => {
    const due = [...queue.values()];
    queue = new Map();
    for (const cb of due) cb(now);
  };
  vi.stubGlobal("requestAnimationFrame", (cb: FrameRequestCallback) => {
    queue.set(next, cb);
    return next++;
  });
  vi.stubGlobal("cancelAnimationFrame", (id: number) => queue.delete(id));
  afterEach(() => queue.clear());

  it("calls once for many asks, and not again within 25 ms", () => {
    let calls = 0;
    const pacer = new FramePacer(() => calls++);
    for (let i = 0; i < 50; i++) pacer.ask();
    run(1000);
    expect(calls).toBe(1);
    pacer.ask();
    run(1010); // 10 ms later: waits for a later frame
    expect(calls).toBe(1);
    run(1026);
    expect(calls).toBe(2);
  });

  it("drops the asked-for call when cancelled", () => {
    let calls = 0;
    const pacer = new FramePacer(() => calls++);
    pacer.ask();
    pacer.cancel();
    run(1000);
    expect(calls).toBe(0);
    pacer.ask(); // and asks again afterwards
    run(2000);
    expect(calls).toBe(1);
  });
});
