import { describe, expect, it } from "vitest";
import type { PlantDetail, RunInfo } from "./protocol.gen";
import { controllerRows, runSettings, signalRows } from "./settings";

const plant = {
  id: "flexible_link",
  reference_output: "theta",
  outputs: [{ name: "theta", unit: "rad", label: "servo angle θ" }],
  states: [
    { name: "theta", unit: "rad", label: "servo angle θ" },
    { name: "alpha", unit: "rad", label: "link deflection α" },
  ],
  inputs: [{ name: "u", unit: "V", label: "motor voltage u" }],
  predefined: { kind: "state_feedback", K: [20, -93.5614], estimate: "velocity_filters", Nr: null },
  predefined_design: "LQR",
  default_signal: { kind: "square", amplitude: Math.PI / 6, period: 4, offset: 0, duty: 0.5 },
  saturate: true,
  u_max: 10,
} as unknown as PlantDetail;

const run = (request: Record<string, unknown>, experiment = "analysis") => ({ request, experiment, mode: "simulation", Ts: 0.001, n_planned: 10_000 }) as unknown as RunInfo;
const rows = (sections: { title: string; rows: [string, string][] }[], title: string) => Object.fromEntries(sections.find((s) => s.title === title)!.rows);

describe("run settings", () => {
  it("shows the reference in degrees and the gains as the form labels them", () => {
    const s = runSettings(run({ controller: { kind: "predefined" }, signal: { kind: "square", amplitude: Math.PI / 6, period: 4, offset: 0, duty: 0.5 }, pace: "realtime", x0: [0.1, 0] }), plant);
    expect(s.map((x) => x.title)).toEqual(["Controller", "Reference for servo angle θ", "Run", "Sensors and amplifier", "Start from"]);
    expect(rows(s, "Controller")).toMatchObject({ controller: "the plant's predefined: LQR", "K1 · servo angle θ": "20 V/rad", "K2 · link deflection α": "-93.5614 V/rad" });
    expect(rows(s, "Reference for servo angle θ")).toEqual({ signal: "square wave", amplitude: "30°", offset: "0°", period: "4 s", "duty cycle": "50 %" });
    expect(rows(s, "Run")).toMatchObject({ duration: "10 s (10,000 samples)", "sample time": "1 ms", pace: "real time" });
    expect(rows(s, "Sensors and amplifier")).toEqual({ "sensor noise": "off", quantisation: "off", "input limit": "±10 V" });
    expect(rows(s, "Start from")["servo angle θ"]).toBe("5.73°");
  });

  it("says a plant with a choice of start state started at its operating point", () => {
    const pendulum = { ...plant, initial_state_ranges: [["beta1", -0.17, 0.17]] } as unknown as PlantDetail;
    expect(rows(runSettings(run({}), pendulum), "Start from")).toEqual({ state: "the operating point" });
    expect(runSettings(run({}), plant).map((s) => s.title)).not.toContain("Start from");
  });

  it("follows the server's sensor defaults: on for identification, noise with a seed", () => {
    expect(rows(runSettings(run({}, "identification"), plant), "Sensors and amplifier")).toMatchObject({ "sensor noise": "on", quantisation: "on (the sensors' resolution)" });
    expect(rows(runSettings(run({ seed: 7, saturate: false }), plant), "Sensors and amplifier")).toEqual({ "sensor noise": "on (seed 7)", quantisation: "off", "input limit": "off" });
    expect(rows(runSettings(run({ noise: false, seed: 7 }), plant), "Sensors and amplifier")["sensor noise"]).toBe("off");
  });

  it("reads PID gains, an excitation at the input and other signals", () => {
    expect(Object.fromEntries(controllerRows({ kind: "pid", Kp: 2, Ki: 0.5, Kd: 0 }, plant))).toMatchObject({ controller: "PID", Kp: "2 V/rad", Ki: "0.5 V/(rad·s)", Kd: "0 V·s/rad" });
    const s = runSettings(run({ controller: { kind: "open_loop" }, excitation: { kind: "prbs", amplitude: 1, order: 10, band: 0.05 }, excitation_at: "input" }), plant);
    expect(rows(s, "Controller")).toEqual({ controller: "none: open loop" });
    expect(rows(s, "Excitation")).toMatchObject({ "added to": "the control signal u", amplitude: "1 V", "register length": "10 bits" });
    expect(Object.fromEntries(signalRows({ kind: "sine", amplitude: 0.1, frequency: 0.5, phase: Math.PI / 2 }, "m"))).toEqual({ signal: "sine", amplitude: "100 mm", frequency: "0.5 Hz", phase: "90°" });
  });
});
