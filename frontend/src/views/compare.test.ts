import { describe, expect, it } from "vitest";
import type { RunInfo } from "../protocol.gen";
import { bothCsv, MAX_SAMPLES, refusal, type Recording } from "./compare";

const run = (id: string, over: Partial<RunInfo> = {}): RunInfo =>
  ({ id, plant: "flexible_link", Ts: 0.001, n_samples: 3, status: "finished", channels: [{ name: "u", unit: "V" }, { name: "theta", unit: "rad" }], ...over }) as RunInfo;

describe("compare", () => {
  it("refuses what cannot be compared, saying why", () => {
    expect(refusal(run("a"), run("b"))).toBeNull();
    expect(refusal(run("a"), run("a"))).toContain("both are run a");
    expect(refusal(run("a"), run("b", { plant: "belt_conveyor" }))).toContain("compare runs of one plant");
    expect(refusal(run("a"), run("b", { Ts: 0.002 }))).toContain("2 ms");
    expect(refusal(run("a", { n_samples: MAX_SAMPLES + 1 }), run("b"))).toContain("download its CSV");
  });

  it("puts both recordings in one CSV, sample by sample, the shorter one's cells empty", () => {
    const ra: Recording = { Ts: 0.001, k0: 0, t: [0, 0.001, 0.002], data: { u: [1, 2, 3], theta: [0.1, 0.2, 0.3] } };
    const rb: Recording = { Ts: 0.001, k0: 0, t: [0, 0.001], data: { u: [5, 6], theta: [0.5, null] } };
    const text = bothCsv(run("a"), ra, run("b"), rb, ["u", "theta"]);
    const lines = text.trim().split("\n");
    expect(lines[0]).toBe("# a: run a (finished); b: run b (finished); plant flexible_link; Ts 0.001 s");
    expect(lines[1]).toBe("t (s),a:u (V),a:theta (rad),b:u (V),b:theta (rad)");
    expect(lines.slice(2)).toEqual(["0,1,0.1,5,0.5", "0.001,2,0.2,6,", "0.002,3,0.3,,"]);
  });
});
