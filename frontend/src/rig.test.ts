import { describe, expect, it } from "vitest";
import type { RigQueueInfo } from "./protocol.gen";
import { clock, endText, latencyStats, latencyText, ordinal, placeText, remaining, rigButtons, rigCondition, rigIdentity, rigStep, rigSummary, startBlocker, startRefusal, waitText } from "./rig";

const NOW = 1_800_000_000;

/** The queue as GET /rig gives it (a free, connected emulated rig; nobody queued). */
function queue(over: Partial<RigQueueInfo> = {}, you: Partial<RigQueueInfo["you"]> = {}, rig: Partial<RigQueueInfo["rig"]> = {}): RigQueueInfo {
  return {
    rig: {
      engine: { id: "rig-0", up: true, problem: null, restarts: 0, pid: 7, heartbeat_age_s: 0.1, live_runs: 0 },
      connected: true,
      rig_id: "emulator-1",
      firmware: "elab-rig-emulator 1",
      emulated: true,
      problem: null,
      settling: false,
      samples: 5000,
      late_1ms: 0,
      latency_p50_us: 42.3,
      latency_p99_us: 66.0,
      latency_max_us: 328.3,
      ...rig,
    },
    in_service: true,
    out_of_service: null,
    settling: false,
    driver: null,
    phase: null,
    run_id: null,
    slot_ends_at: null,
    taken_over: false,
    waiting: 0,
    slot_s: 300,
    grace_s: 60,
    you: { place: null, wait_s: null, driving: false, arm_by: null, ...you },
    now: NOW,
    ...over,
  };
}

const seated = (you: Partial<RigQueueInfo["you"]> = {}) => queue({ driver: "guest 3f2a", phase: "seated", slot_ends_at: NOW + 300 }, you);
const armed = (you: Partial<RigQueueInfo["you"]> = {}) => queue({ driver: "guest 3f2a", phase: "armed", slot_ends_at: NOW + 300 }, you);
const running = (you: Partial<RigQueueInfo["you"]> = {}, over: Partial<RigQueueInfo> = {}) => queue({ driver: "guest 3f2a", phase: "running", run_id: "r1", slot_ends_at: NOW + 250, ...over }, you);
const ME_DRIVING = { place: 1, wait_s: 0, driving: true };
const ME_SECOND = { place: 2, wait_s: 250, driving: false };

describe("rigCondition", () => {
  it("puts what stops everyone first, then who holds it", () => {
    expect(rigCondition(queue())).toBe("free");
    expect(rigCondition(running())).toBe("in_use");
    expect(rigCondition(queue({ settling: true }))).toBe("settling");
    expect(rigCondition(queue({}, {}, { connected: false, problem: "refused" }))).toBe("offline");
    expect(rigCondition(running({}, { in_service: false, out_of_service: "did not settle in 60 s" }))).toBe("out_of_service");
  });
});

describe("rigStep and rigButtons", () => {
  it("walks the caller from join to arm to start", () => {
    expect(rigStep(queue())).toBe("join");
    expect(rigStep(running(ME_SECOND))).toBe("wait");
    expect(rigStep(seated({ ...ME_DRIVING, arm_by: NOW + 60 }))).toBe("arm");
    expect(rigStep(armed(ME_DRIVING))).toBe("start");
    expect(rigStep(running(ME_DRIVING))).toBe("running");
  });

  it("shows each student the button of their step, and leave once queued", () => {
    const none = { join: false, leave: false, arm: false, estop: false, takeover: false, extend: false, clear: false };
    expect(rigButtons(queue(), "student")).toEqual({ ...none, join: true });
    expect(rigButtons(running(ME_SECOND, { waiting: 1 }), "student")).toEqual({ ...none, leave: true });
    expect(rigButtons(seated(ME_DRIVING), "student")).toEqual({ ...none, arm: true, leave: true });
    expect(rigButtons(armed(ME_DRIVING), "student")).toEqual({ ...none, leave: true });
    expect(rigButtons(running(ME_DRIVING), "student")).toEqual({ ...none, leave: true, estop: true });
  });

  it("gives the emergency stop to the driver and instructors only", () => {
    expect(rigButtons(running(), "student").estop).toBe(false); // a spectator
    expect(rigButtons(running(ME_SECOND), "student").estop).toBe(false);
    expect(rigButtons(running(), "instructor").estop).toBe(true);
    expect(rigButtons(armed(), "instructor").estop).toBe(false); // nothing runs
  });

  it("gives instructors take over, extend and clear where they mean something", () => {
    const free = rigButtons(queue(), "instructor");
    expect([free.takeover, free.extend, free.clear]).toEqual([true, false, false]);
    const busy = rigButtons(running({}, { waiting: 2 }), "instructor");
    expect([busy.takeover, busy.extend, busy.clear]).toEqual([true, true, true]);
    const mine = rigButtons(running({ ...ME_DRIVING }, { taken_over: true }), "instructor");
    expect([mine.takeover, mine.extend]).toEqual([false, true]); // already holds it
    const student = rigButtons(running({}, { waiting: 2 }), "student");
    expect([student.takeover, student.extend, student.clear]).toEqual([false, false, false]);
  });

  it("lets nobody join or arm a rig out of service, nor arm an offline one", () => {
    expect(rigButtons(queue({ in_service: false, out_of_service: "x" }), "student").join).toBe(false);
    expect(rigButtons(seated(ME_DRIVING), "student").arm).toBe(true);
    const offline = queue({ driver: "me", phase: "seated" }, ME_DRIVING, { connected: false });
    expect(rigButtons(offline, "student").arm).toBe(false);
  });
});

describe("startBlocker and startRefusal", () => {
  it("lets an armed driver start, and says what to do otherwise", () => {
    expect(startBlocker(armed(ME_DRIVING))).toBeNull();
    expect(startBlocker(queue())).toMatch(/Join the rig's queue first/);
    expect(startBlocker(running(ME_SECOND))).toMatch(/not your turn yet: you are 2nd in the queue, about 4 min/);
    expect(startBlocker(seated(ME_DRIVING))).toMatch(/arm the rig first/);
    expect(startBlocker(queue({ driver: "me", phase: "armed", settling: true }, ME_DRIVING))).toMatch(/settling.*in a few seconds/);
    expect(startBlocker(queue({}, {}, { connected: false, problem: "connection refused" }))).toMatch(/offline \(connection refused\).*simulation/);
    expect(startBlocker(queue({ in_service: false, out_of_service: "the link did not settle in 60 s" }))).toMatch(/out of service: the link did not settle/);
  });

  it("turns the server's refusals into the next step", () => {
    expect(startRefusal(409, "the rig is settling after the last run; retry")).toMatch(/Press Start again in a few seconds/);
    expect(startRefusal(409, "your seat on the rig is seated: arm it before starting")).toMatch(/arm it before starting\. Join the queue and arm the rig/);
    expect(startRefusal(503, "the rig is not connected: refused")).toMatch(/Run in simulation, or try again/);
    expect(startRefusal(422, "controller.estimate: velocity_filters or observer")).toBe("controller.estimate: velocity_filters or observer");
  });
});

describe("times in words", () => {
  it("counts down in m:ss, h:mm:ss past an hour, never below zero", () => {
    expect(clock(0)).toBe("0:00");
    expect(clock(-3)).toBe("0:00");
    expect(clock(4.2)).toBe("0:05"); // a second not yet over still shows
    expect(clock(245)).toBe("4:05");
    expect(clock(3729)).toBe("1:02:09");
  });

  it("estimates waits roughly, as estimates are", () => {
    expect(waitText(null)).toBe("wait unknown");
    expect(waitText(0)).toBe("your turn now");
    expect(waitText(12)).toBe("about 15 s");
    expect(waitText(250)).toBe("about 4 min");
    expect(waitText(3900)).toBe("about 1 h 5 min");
    expect(waitText(7200)).toBe("about 2 h");
  });

  it("reads the time left on the server's clock, whatever the page's clock says", () => {
    const q = { now: NOW };
    const received = 5_000_000; // the page's ms when the queue arrived (its clock is off)
    expect(remaining(NOW + 60, q, received, received)).toBe(60);
    expect(remaining(NOW + 60, q, received, received + 15_000)).toBe(45);
  });

  it("says 1st, 2nd, 3rd, 11th, 22nd", () => {
    expect([1, 2, 3, 4, 11, 12, 13, 21, 22, 101].map(ordinal)).toEqual(["1st", "2nd", "3rd", "4th", "11th", "12th", "13th", "21st", "22nd", "101st"]);
  });
});

describe("rigSummary and friends", () => {
  it("never passes an emulator off as hardware", () => {
    expect(rigIdentity(queue().rig)).toBe("emulated rig emulator-1 (elab rig-emulator, not hardware)");
    expect(rigIdentity(queue({}, {}, { emulated: false, rig_id: "srv02-7", firmware: "2.1" }).rig)).toBe("rig srv02-7, firmware 2.1");
  });

  it("says who holds the rig, how many wait and how fast the loop answers", () => {
    const s = rigSummary(running({}, { waiting: 2 }));
    expect(s.headline).toBe("In use by guest 3f2a (running a run)");
    expect(s.details).toEqual(["2 waiting", "loop latency p50 42 µs · p99 66 µs · max 328 µs (last 10 s)"]);
    expect(rigSummary(queue()).headline).toBe("Online and free");
    expect(rigSummary(running(ME_DRIVING)).headline).toBe("In use by you (running a run)");
    expect(rigSummary(running({}, { taken_over: true, driver: "prof (instructor)" })).headline).toBe("In use by prof (instructor) (taken over) (running a run)");
    const off = rigSummary(queue({}, {}, { connected: false, problem: "the rig is not connected: refused" }));
    expect(off.headline).toBe("Offline: the rig is not connected: refused");
    expect(off.details).toEqual(["nobody waiting"]); // no latency from a rig that is not there
    expect(latencyText(queue({}, {}, { latency_p50_us: null, latency_p99_us: null, latency_max_us: null }).rig)).toBeNull();
  });

  it("tells the caller where they stand", () => {
    expect(placeText(queue())).toBeNull();
    expect(placeText(running(ME_SECOND))).toBe("You are 2nd in the queue: about 4 min.");
    expect(placeText(seated(ME_DRIVING))).toBe("Your turn: arm the rig to start.");
    expect(placeText(running(ME_DRIVING))).toBe("You drive the rig: your run is on it.");
  });
});

describe("a rig run's latency and end", () => {
  it("takes percentiles of the latency channel, leaving gaps out", () => {
    const v = new Float32Array(1000).map((_, i) => (i + 1) * 1e-6); // 1 … 1000 µs
    v[10] = NaN;
    const st = latencyStats([...v, 2e-3, 3e-3])!;
    expect(st.n).toBe(1001);
    // sorted: 1 … 10, 12 … 1000 µs (11 was the gap), 2 ms, 3 ms; the k-th from k = 11 on is k + 1 µs
    expect(st.p50 * 1e6).toBeCloseTo(502, 3); // the ceil(0.5 · 1001) = 501st
    expect(st.p99 * 1e6).toBeCloseTo(992, 3); // the ceil(0.99 · 1001) = 991st
    expect(st.max).toBeCloseTo(3e-3, 9);
    expect(st.late).toBe(2);
    expect(latencyStats([])).toBeNull();
  });

  it("names a safety trip and an emergency stop", () => {
    expect(endText("failed", "safety trip (angle) at sample 1234: θ = 2.1 rad beyond ±2.094 rad for 10 samples in a row")).toMatchObject({ kind: "trip", title: "Safety trip: the supervisor stopped the motor" });
    expect(endText("stopped", "emergency stop by guest 3f2a")).toMatchObject({ kind: "estop", title: "Emergency stop" });
    expect(endText("stopped", "stopped by its owner")).toMatchObject({ kind: "other", title: "Run stopped" });
    expect(endText("finished", null)).toBeNull();
  });
});
