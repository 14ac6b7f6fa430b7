// @ts-check
/**
 * JS time per drawn frame (update + render calls), kept in a fixed ring so that measuring allocates
 * nothing per frame: the numbers behind the frame-time regression budget (test-artifacts/frame_timing.json).
 */

export class FrameTimer {
  /** @param {number} [capacity] samples kept */
  constructor(capacity = 1200) {
    this.samples = new Float32Array(capacity);
    this.count = 0;
  }

  /** @param {number} ms */
  record(ms) {
    this.samples[this.count % this.samples.length] = ms;
    this.count++;
  }

  /** The last n samples, oldest first, rounded to 0.1 ms. @param {number} n */
  recent(n) {
    const k = Math.min(n, this.count, this.samples.length);
    const out = [];
    for (let i = this.count - k; i < this.count; i++)
      out.push(Math.round(this.samples[i % this.samples.length] * 10) / 10);
    return out;
  }

  /** Quantiles over the samples kept. */
  stats() {
    const times = Array.from(this.samples.slice(0, Math.min(this.count, this.samples.length))).sort((a, b) => a - b);
    const q = (/** @type {number} */ p) =>
      times.length ? times[Math.min(times.length - 1, Math.floor(p * times.length))] : null;
    return {
      samples: times.length,
      p50: q(0.5),
      p95: q(0.95),
      p99: q(0.99),
      max: times.length ? times[times.length - 1] : null,
    };
  }
}
