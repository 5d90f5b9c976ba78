import { describe, expect, it } from "vitest";
import schema from "../../shared/elab.v1.schema.json";
import type { ServerMessage } from "./protocol.gen";
import { identLine, serverMessage, WireError } from "./wire";

const run = {
  id: "r-1", plant: "flexible_link", mode: "simulation", experiment: "analysis", status: "running", Ts: 0.001,
  channels: [{ name: "y", unit: "rad" }], n_planned: 10, n_samples: 0, created_at: 0, started_at: 0,
  finished_at: null, error: null, compute: null, outcome: null, url: "/api/v1/runs/r-1", frame_samples: 20, stream_url: "/s", data_url: "/d",
  request: {}, param_changes: [], owner: "guest 3f2a", private: false, mine: true, can_control: true,
};
const VALID: Record<ServerMessage["type"], ServerMessage> = {
  hello: { type: "hello", protocol: "elab.v1", run: { ...run, status: "running" }, live_seq: 3 },
  frame: { type: "frame", seq: 1, k0: 20, n: 20, columns: { y: new Uint8Array(80) } },
  status: { type: "status", state: "interrupted", k: 40, error: "the engine process ended" },
  skipped: { type: "skipped", from_seq: 2, to_seq: 5, reason: "slow watcher" },
  params: { type: "params", k: 7, t: 0.007, params: { controller: { kind: "pid", Kp: 1 } } },
  error: { type: "error", code: "conflict", message: "run r-1 has ended", field: null },
};
const TITLES: Record<ServerMessage["type"], string> = {
  hello: "Hello", frame: "Frame", status: "Status", skipped: "Skipped", params: "ParamsNotice", error: "ErrorMessage",
};
const defs = (schema as { $defs: Record<string, { required?: string[] }> }).$defs;

describe("serverMessage", () => {
  it("accepts every message type the schema has", () => {
    for (const msg of Object.values(VALID)) expect(serverMessage(msg)).toBe(msg);
  });
  it("refuses each message without any field the schema requires, naming it", () => {
    for (const [type, msg] of Object.entries(VALID)) {
      const required = defs[TITLES[type as ServerMessage["type"]]].required ?? [];
      expect(required.length).toBeGreaterThan(1);
      for (const field of required) {
        const broken: Record<string, unknown> = { ...msg };
        delete broken[field];
        expect(() => serverMessage(broken), `${type} without ${field}`).toThrow(WireError);
      }
    }
  });
  it("refuses wrong types, unknown states and messages, and columns that are not bytes", () => {
    const bad: unknown[] = [
      { ...VALID.status, state: "exploded" },
      { ...VALID.skipped, from_seq: "2" },
      { ...VALID.frame, columns: { y: [1, 2, 3] } },
      { ...VALID.hello, run: { ...run, Ts: "fast" } },
      { ...VALID.error, extra: 1 },
      { type: "fireworks" },
      null,
      [1, 2],
    ];
    for (const b of bad) expect(() => serverMessage(b), JSON.stringify(b)).toThrow(WireError);
    expect(() => serverMessage({ ...VALID.status, state: "exploded" })).toThrow(/state/);
  });
});

describe("identLine", () => {
  it("accepts a progress line and refuses one whose fields have the wrong type, naming the field", () => {
    const line = { progress: { stage: "arx", done: 0.5 }, result: null, error: null };
    expect(identLine(line)).toBe(line);
    expect(() => identLine({ ...line, progress: { stage: "arx", done: "half" } })).toThrow(/progress\/done/);
  });
});
