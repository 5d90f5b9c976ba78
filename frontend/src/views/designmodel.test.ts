import { describe, expect, it } from "vitest";
import type { StepOut } from "../protocol.gen";
import { disagreement } from "./designmodel";

const step = (overshoot: number | null, settling: number | null, verdict = "asymptotically stable"): StepOut => ({
  plant: "flexible_link",
  loop: "closed",
  t: [0, 1, 2, 3],
  outputs: {},
  u: [],
  info: { rise_time: 0.1, settling_time: settling, overshoot, peak: null, peak_time: null, steady_state: null, steady_state_error: null },
  poles: [],
  verdict,
  cut: null,
});

describe("disagreement (issue 26: a design on an identified model, checked on the physics)", () => {
  it("says nothing where the two agree", () => {
    expect(disagreement(step(5, 0.6), step(8, 0.7), "asymptotically stable")).toBeNull();
  });
  it("names overshoot or settling far apart, with both numbers", () => {
    const said = disagreement(step(0, 0.2), step(30, 1.5), "asymptotically stable");
    expect(said).toContain("overshoots 30 % and settles in 1.5 s; the identified model predicts 0 % and 0.2 s");
    expect(said).toContain("before running it on the rig");
  });
  it("names a response that does not settle on the physics model", () => {
    expect(disagreement(step(0, 0.2), step(null, null), "asymptotically stable")).toContain("does not settle within 3 s");
  });
  it("names another verdict", () => {
    expect(disagreement(step(0, 0.2), step(null, null, "unstable"), "asymptotically stable")).toContain("this design is unstable; the identified model says asymptotically stable");
  });
});
