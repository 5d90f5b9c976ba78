import { decode, encode } from "@msgpack/msgpack";
import { afterEach, beforeEach, describe, expect, it, vi } from "vitest";
import type { RunInfo } from "./protocol.gen";
import { RunStream, type SocketLike, type StreamListener } from "./stream";

const F = 20;

class FakeSocket implements SocketLike {
  binaryType: BinaryType = "blob";
  readyState = 1;
  onopen: ((ev: Event) => unknown) | null = null;
  onmessage: ((ev: MessageEvent) => unknown) | null = null;
  onclose: ((ev: CloseEvent) => unknown) | null = null;
  onerror: ((ev: Event) => unknown) | null = null;
  sent: Record<string, unknown>[] = [];
  closed: number | null = null;
  constructor(readonly url: string) {}
  send(data: Uint8Array): void {
    this.sent.push(decode(data) as Record<string, unknown>);
  }
  close(code = 1000): void {
    this.closed = code;
    this.readyState = 3;
  }
  // server side
  deliver(msg: unknown): void {
    const bytes = encode(msg);
    const buf = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
    this.onmessage?.({ data: buf } as MessageEvent);
  }
  drop(code = 1006): void {
    this.readyState = 3;
    this.onclose?.({ code, reason: "" } as CloseEvent);
  }
}

function run(status = "running", n_samples = 0): RunInfo {
  return {
    id: "r-1", plant: "flexible_link", mode: "simulation", experiment: "analysis", status: status as RunInfo["status"], Ts: 0.001,
    channels: [{ name: "y", unit: "rad" }], n_planned: 10_000, n_samples, frame_samples: F, created_at: 0, started_at: 0,
    finished_at: null, error: null, compute: null, outcome: null, url: "/api/v1/runs/r-1", stream_url: "/api/v1/runs/r-1/stream", data_url: "/api/v1/runs/r-1/data", request: {}, param_changes: [],
    owner: "guest 3f2a", private: false, mine: true, can_control: true,
  };
}

/** Frame starting at k0 with n samples whose values are their own indices. */
function frame(k0: number, n = F) {
  const y = Float32Array.from({ length: n }, (_, i) => k0 + i);
  return { type: "frame", seq: Math.floor(k0 / F), k0, n, columns: { y: new Uint8Array(y.buffer) } };
}

describe("RunStream", () => {
  let sockets: FakeSocket[];
  let got: number[];
  let listener: StreamListener & { completed?: number };
  const open = (fromSeq?: number) =>
    new RunStream("/api/v1/runs/r-1/stream", listener, {
      fromSeq,
      backoff: [100, 200],
      location: { protocol: "http:", host: "lab:8000" },
      socket: (url) => {
        const s = new FakeSocket(url);
        sockets.push(s);
        return s;
      },
    }).open();

  beforeEach(() => {
    sockets = [];
    got = [];
    listener = {
      samples: (k0, n, cols) => {
        for (let i = 0; i < n; i++) {
          expect(cols.y[i]).toBe(k0 + i); // the right values at the right indices
          got.push(k0 + i);
        }
      },
      complete: (n) => (listener.completed = n),
    };
  });
  afterEach(() => vi.useRealTimers());

  it("connects with the subprotocol's URL and starts at the live edge", () => {
    open();
    expect(sockets[0].url).toBe("ws://lab:8000/api/v1/runs/r-1/stream");
    sockets[0].deliver({ type: "hello", protocol: "elab.v1", run: run(), live_seq: 5 });
    sockets[0].deliver(frame(100));
    sockets[0].deliver(frame(120));
    expect(got).toEqual(Array.from({ length: 40 }, (_, i) => 100 + i));
  });

  it("trims overlapping frames and delivers every sample once", () => {
    open(0);
    expect(sockets[0].url).toContain("?from_seq=0");
    sockets[0].deliver({ type: "hello", protocol: "elab.v1", run: run(), live_seq: 0 });
    sockets[0].deliver(frame(0, 60)); // a pulled message of three frames
    sockets[0].deliver(frame(40)); // overlaps entirely
    sockets[0].deliver(frame(60));
    expect(got).toEqual(Array.from({ length: 80 }, (_, i) => i));
  });

  it("asks once to resume from the recording when a gap or a skipped notice appears", () => {
    open(0);
    const s = sockets[0];
    s.deliver({ type: "hello", protocol: "elab.v1", run: run(), live_seq: 0 });
    s.deliver(frame(0));
    s.deliver({ type: "skipped", from_seq: 1, to_seq: 3, reason: "slow" });
    s.deliver(frame(80)); // in flight, beyond the gap
    s.deliver(frame(100));
    expect(s.sent).toEqual([{ type: "resume_from", seq: 1 }]);
    s.deliver(frame(20, 100)); // the recording fills 20..119
    s.deliver(frame(120));
    expect(got).toEqual(Array.from({ length: 140 }, (_, i) => i));
  });

  it("reconnects after a blip from the next missing frame, without losing or repeating samples", () => {
    vi.useFakeTimers();
    const states: string[] = [];
    listener.connection = (st) => states.push(st);
    open(0);
    sockets[0].deliver({ type: "hello", protocol: "elab.v1", run: run(), live_seq: 0 });
    sockets[0].deliver(frame(0));
    sockets[0].deliver(frame(20, 7)); // a partial frame (e.g. the run paused mid-frame)
    sockets[0].drop();
    expect(states).toContain("reconnecting");
    vi.advanceTimersByTime(100);
    expect(sockets[1].url).toContain("?from_seq=1"); // sample 27 lies in frame 1
    sockets[1].deliver({ type: "hello", protocol: "elab.v1", run: run(), live_seq: 3 });
    sockets[1].deliver(frame(20, 40));
    expect(got).toEqual(Array.from({ length: 60 }, (_, i) => i));
  });

  it("completes an ended run and closes; an unknown run is not retried", () => {
    vi.useFakeTimers();
    open();
    sockets[0].deliver({ type: "hello", protocol: "elab.v1", run: run("finished", 30), live_seq: 2 });
    sockets[0].deliver(frame(0));
    sockets[0].deliver({ type: "status", state: "finished", k: 30, error: null });
    expect(listener.completed).toBeUndefined();
    sockets[0].deliver(frame(20, 10));
    expect(listener.completed).toBe(30);
    expect(sockets[0].closed).toBe(1000);

    // a recording that holds fewer samples than were streamed (its engine died before
    // storing them): complete with the recording's count
    open();
    sockets[1].deliver({ type: "hello", protocol: "elab.v1", run: run("running", 0), live_seq: 0 });
    sockets[1].deliver(frame(0, 30));
    sockets[1].deliver({ type: "status", state: "interrupted", k: 24, error: "the engine died" });
    expect(listener.completed).toBe(24);

    const other = open();
    sockets[2].drop(4404);
    vi.advanceTimersByTime(10_000);
    expect(sockets).toHaveLength(3);
    other.close();
  });
});
