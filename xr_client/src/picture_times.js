// @ts-check
/**
 * When each camera picture became drawable on this page: the publisher's stamp (the frame header's `stamp`) beside
 * the page's clock (`performance.now()`, ms) at the moment its decode finished (a WebCodecs `VideoFrame` output, or
 * a JPEG's `createImageBitmap` resolving). Kept in a fixed ring so recording allocates nothing per picture. The video
 * benchmark reads it (`window.__xrRelay.pictureTimes`) and maps the page's clock onto the publisher's to measure
 * publisher-to-decoded latency (bench/bench_video.py).
 */

export class PictureTimes {
  /** @param {number} [capacity] pictures kept */
  constructor(capacity = 600) {
    this.values = new Float64Array(2 * capacity);
    this.capacity = capacity;
    this.count = 0;
  }

  /** @param {number} stamp the picture's header stamp (s, the publisher's clock) @param {number} at page time (ms) */
  record(stamp, at) {
    const i = 2 * (this.count % this.capacity);
    this.values[i] = stamp;
    this.values[i + 1] = at;
    this.count++;
  }

  /** The last n pictures, oldest first, as [stamp, at] pairs. @param {number} n @returns {[number, number][]} */
  recent(n) {
    const k = Math.min(n, this.count, this.capacity);
    /** @type {[number, number][]} */
    const out = [];
    for (let c = this.count - k; c < this.count; c++) {
      const i = 2 * (c % this.capacity);
      out.push([this.values[i], this.values[i + 1]]);
    }
    return out;
  }
}
