// The live stream of a run (websocket, subprotocol elab.v1, msgpack). The client hands
// its listener every sample exactly once and in order: frames that overlap what it has
// are trimmed, a gap (a skipped notice, a frame beyond the next sample) asks the server
// to resume from the recording, and after a network blip it reconnects by itself from
// the next missing frame.
import { decode, encode } from "@msgpack/msgpack";
import type { ClientMessage, CloseCode, ErrorMessage, Hello, ParamsNotice, RunInfo, Status } from "./protocol.gen";
import { serverMessage, WireError } from "./wire";

export const PROTOCOL = "elab.v1";
/** The server's close codes (CloseCode in the schema), and whether to reconnect after
 * each. A code the schema adds fails the type check here until it is handled. */
const CLOSES: Record<CloseCode, { text: string; retry: boolean }> = {
  4400: { text: "the request was refused", retry: false },
  4404: { text: "no such run", retry: false },
  4408: { text: "the page did not read the stream", retry: true },
  4429: { text: "too many streams open", retry: false },
};
const ENDED = new Set(["finished", "stopped", "failed", "interrupted"]);

export interface StreamListener {
  hello?(run: RunInfo, live: boolean): void;
  /** Samples k0 .. k0+n−1, one Float32Array per channel (t = k·Ts). */
  samples?(k0: number, n: number, columns: Record<string, Float32Array>): void;
  status?(status: Status): void;
  params?(notice: ParamsNotice): void;
  error?(error: ErrorMessage): void;
  connection?(state: "connecting" | "open" | "reconnecting" | "closed", detail?: string): void;
  /** Every sample of an ended run has arrived: `n`, the samples its recording holds (fewer
   * than were streamed if its engine died or its store failed before storing them). */
  complete?(n: number): void;
}

/** A websocket as the client uses it (the browser's, or a test double). */
export interface SocketLike {
  binaryType: BinaryType;
  readyState: number;
  onopen: ((ev: Event) => unknown) | null;
  onmessage: ((ev: MessageEvent) => unknown) | null;
  onclose: ((ev: CloseEvent) => unknown) | null;
  onerror: ((ev: Event) => unknown) | null;
  send(data: ArrayBufferLike | Uint8Array): void;
  close(code?: number, reason?: string): void;
}

export type SocketFactory = (url: string, protocol: string) => SocketLike;

export interface StreamOptions {
  /** First frame wanted (default: the live edge, or 0 for an ended run). */
  fromSeq?: number;
  socket?: SocketFactory;
  /** Reconnect delays in ms (the last repeats). */
  backoff?: number[];
  location?: { protocol: string; host: string };
}

/** Float32 little-endian bytes → Float32Array, without copying when aligned. */
export function floats(bytes: Uint8Array): Float32Array {
  if (bytes.byteOffset % 4 === 0) return new Float32Array(bytes.buffer, bytes.byteOffset, bytes.byteLength / 4);
  return new Float32Array(bytes.slice().buffer);
}

export class RunStream {
  /** The next sample this client needs (all before it have been delivered). */
  next = 0;
  run: RunInfo | null = null;
  private F = 1;
  private ws: SocketLike | null = null;
  private resumeAsked: number | null = null;
  private attempts = 0;
  private closedByUser = false;
  private ended = false;
  private endK: number | null = null;
  private timer: ReturnType<typeof setTimeout> | null = null;
  private readonly socket: SocketFactory;
  private readonly backoff: number[];

  constructor(
    readonly streamUrl: string,
    private readonly listener: StreamListener,
    private readonly options: StreamOptions = {},
  ) {
    this.socket = options.socket ?? ((url, protocol) => new WebSocket(url, protocol) as SocketLike);
    this.backoff = options.backoff ?? [250, 500, 1000, 2000, 4000];
  }

  open(): this {
    this.connect(this.options.fromSeq);
    return this;
  }

  close(): void {
    this.closedByUser = true;
    if (this.timer) clearTimeout(this.timer);
    this.ws?.close(1000, "done");
    this.listener.connection?.("closed");
  }

  send(message: ClientMessage): boolean {
    if (!this.ws || this.ws.readyState !== 1) return false;
    this.ws.send(encode(message));
    return true;
  }

  private url(fromSeq: number | undefined): string {
    const loc = this.options.location ?? window.location;
    const scheme = loc.protocol === "https:" ? "wss:" : "ws:";
    const base = /^wss?:/.test(this.streamUrl) ? this.streamUrl : `${scheme}//${loc.host}${this.streamUrl}`;
    return fromSeq === undefined ? base : `${base}?from_seq=${fromSeq}`;
  }

  private connect(fromSeq: number | undefined): void {
    this.listener.connection?.(this.attempts ? "reconnecting" : "connecting");
    const ws = this.socket(this.url(fromSeq), PROTOCOL);
    ws.binaryType = "arraybuffer";
    this.ws = ws;
    this.resumeAsked = null;
    ws.onmessage = (ev) => this.receive(new Uint8Array(ev.data as ArrayBuffer));
    ws.onclose = (ev) => this.closed(ev);
    ws.onerror = () => undefined; // onclose follows with the reason
  }

  private closed(ev: CloseEvent): void {
    this.ws = null;
    if (this.closedByUser || this.ended) return;
    const known = ev.code in CLOSES ? CLOSES[ev.code as CloseCode] : null;
    if (known && !known.retry) {
      this.listener.connection?.("closed", ev.reason || known.text);
      return;
    }
    const delay = this.backoff[Math.min(this.attempts, this.backoff.length - 1)];
    this.attempts += 1;
    this.listener.connection?.("reconnecting", `connection lost; retrying in ${delay} ms`);
    this.timer = setTimeout(() => this.connect(Math.floor(this.next / this.F)), delay);
  }

  private receive(bytes: Uint8Array): void {
    let msg;
    try {
      msg = serverMessage(decode(bytes));
    } catch (e) {
      const message = e instanceof WireError ? e.message : `not msgpack: ${String(e)}`;
      this.listener.error?.({ type: "error", code: "invalid", message, field: null });
      return;
    }
    switch (msg.type) {
      case "hello":
        return this.hello(msg);
      case "frame":
        return this.frame(msg.k0, msg.n, msg.columns);
      case "skipped":
        return this.askResume();
      case "status":
        this.listener.status?.(msg);
        if (ENDED.has(msg.state)) {
          this.endK = msg.k;
          this.checkComplete();
        }
        return;
      case "params":
        return this.listener.params?.(msg);
      case "error":
        return this.listener.error?.(msg);
      default: {
        const unknown: never = msg; // every message type of the schema is handled above
        return unknown;
      }
    }
  }

  private hello(msg: Hello): void {
    const first = this.run === null;
    this.run = msg.run;
    this.F = msg.run.frame_samples;
    this.attempts = 0;
    this.listener.connection?.("open");
    if (first) {
      const start = this.options.fromSeq ?? (ENDED.has(msg.run.status) ? 0 : msg.live_seq);
      this.next = start * this.F;
    }
    this.listener.hello?.(msg.run, !ENDED.has(msg.run.status));
  }

  private frame(k0: number, n: number, raw: Record<string, Uint8Array>): void {
    if (k0 > this.next) return this.askResume(); // a gap: fetch it from the recording
    const skip = this.next - k0;
    if (skip >= n) return; // already have all of it
    this.resumeAsked = null;
    const columns: Record<string, Float32Array> = {};
    for (const [name, b] of Object.entries(raw)) columns[name] = floats(b).subarray(skip, n);
    this.listener.samples?.(this.next, n - skip, columns);
    this.next += n - skip;
    this.checkComplete();
  }

  private askResume(): void {
    const seq = Math.floor(this.next / this.F);
    if (this.resumeAsked === seq) return; // already asked; frames in flight are ignored
    this.resumeAsked = seq;
    this.send({ type: "resume_from", seq });
  }

  private checkComplete(): void {
    if (this.endK === null || this.next < this.endK || this.ended) return;
    this.ended = true;
    this.listener.complete?.(this.endK); // the recording's samples: frames past it were lost
    this.ws?.close(1000, "complete");
    this.listener.connection?.("closed", "run complete");
  }
}
