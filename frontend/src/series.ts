// Samples kept in the browser: a ring buffer per channel in typed arrays, and the
// min/max decimation that turns any span of it into at most two points per pixel column.

/** The last `capacity` samples of each channel; sample k sits at k mod capacity. */
export class SampleRing {
  readonly data: Record<string, Float32Array> = {};
  /** One past the newest sample held (samples [end − size, end) are held). */
  end = 0;
  size = 0;

  constructor(
    readonly names: string[],
    readonly capacity: number,
  ) {
    if (!(capacity >= 1)) throw new RangeError(`capacity: got ${capacity}; allowed: ≥ 1`);
    for (const name of names) this.data[name] = new Float32Array(capacity);
  }

  get start(): number {
    return this.end - this.size;
  }

  /** Append samples k0 .. k0+n−1 (k0 must be `end`, or the ring restarts at k0). */
  push(k0: number, n: number, columns: Record<string, Float32Array>): void {
    if (k0 !== this.end) {
      this.end = k0;
      this.size = 0;
    }
    const cap = this.capacity;
    const from = Math.max(0, n - cap); // only the last `cap` samples can stay
    for (const name of this.names) {
      const src = columns[name];
      const dst = this.data[name];
      if (!src) continue;
      let k = k0 + from;
      let i = from;
      while (i < n) {
        const at = k % cap;
        const len = Math.min(n - i, cap - at);
        dst.set(src.subarray(i, i + len), at);
        i += len;
        k += len;
      }
    }
    this.end = k0 + n;
    this.size = Math.min(cap, this.size + n);
  }

  /** Keep only samples before `end` (a run's recording can hold fewer than were streamed:
   * samples not yet stored when its engine died or its store failed). */
  truncate(end: number): void {
    if (end >= this.end) return;
    this.size = Math.max(0, this.size - (this.end - end));
    this.end = Math.max(end, 0);
  }

  /** Sample k of a channel (k within [start, end)). */
  at(name: string, k: number): number {
    return this.data[name][k % this.capacity];
  }

  clear(): void {
    this.end = 0;
    this.size = 0;
  }
}

export interface Decimated {
  /** Sample indices (times are k·Ts). */
  k: Float64Array;
  y: Float32Array;
  length: number;
}

/**
 * Samples [k0, k1) of one ring channel reduced to at most 2·columns points: for each pixel
 * column its minimum and maximum, in the order they occur, so every peak stays visible and
 * the line looks as if every sample were drawn. Spans of ≤ 2·columns samples come back whole.
 * Non-finite samples are skipped.
 */
export function decimate(ring: SampleRing, name: string, k0: number, k1: number, columns: number): Decimated {
  k0 = Math.max(k0, ring.start);
  k1 = Math.min(k1, ring.end);
  const n = Math.max(0, k1 - k0);
  const cols = Math.max(1, Math.floor(columns));
  const src = ring.data[name];
  const cap = ring.capacity;
  if (n <= 2 * cols) {
    const k = new Float64Array(n);
    const y = new Float32Array(n);
    for (let i = 0; i < n; i++) {
      k[i] = k0 + i;
      y[i] = src[(k0 + i) % cap];
    }
    return { k, y, length: n };
  }
  const k = new Float64Array(2 * cols);
  const y = new Float32Array(2 * cols);
  let out = 0;
  for (let c = 0; c < cols; c++) {
    const a = k0 + Math.floor((c * n) / cols);
    const b = k0 + Math.floor(((c + 1) * n) / cols);
    let lo = Infinity;
    let hi = -Infinity;
    let kLo = a;
    let kHi = a;
    for (let j = a; j < b; j++) {
      const v = src[j % cap];
      if (v < lo) {
        lo = v;
        kLo = j;
      }
      if (v > hi) {
        hi = v;
        kHi = j;
      }
    }
    if (lo === Infinity) continue; // a column of NaN only
    if (kLo <= kHi) {
      k[out] = kLo;
      y[out++] = lo;
      if (kHi !== kLo) {
        k[out] = kHi;
        y[out++] = hi;
      }
    } else {
      k[out] = kHi;
      y[out++] = hi;
      k[out] = kLo;
      y[out++] = lo;
    }
  }
  return { k: k.subarray(0, out), y: y.subarray(0, out), length: out };
}
