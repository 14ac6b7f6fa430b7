// @ts-check
/**
 * Binary camera frames (docs/protocol.md, "Binary frames"): a big-endian u32 header length, a UTF-8 JSON
 * header, then the encoded image. The client never guesses a size: width and height come from the header.
 * And the decode scheduling rule: one decode in flight, newest wins.
 */
import { FRAME_PREFIX_BYTES } from './protocol.js';

/**
 * @typedef {{identifier: string, seq: number, stamp: number, encoding: string, width: number, height: number,
 *   lens: import('./lens.js').Lens, request_id: string | number | null, keyframe?: boolean, codec?: string}}
 *   FrameHeader (`keyframe` and `codec`: H.264 frames only)
 */

/**
 * @param {ArrayBuffer} buffer
 * @returns {{header: FrameHeader, payload: Uint8Array}}
 */
export function parseFrame(buffer) {
  if (buffer.byteLength < FRAME_PREFIX_BYTES) throw new Error('camera frame shorter than its header length');
  const length = new DataView(buffer).getUint32(0, false);
  const end = FRAME_PREFIX_BYTES + length;
  if (end > buffer.byteLength) throw new Error(`camera frame header length ${length} exceeds the frame`);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, FRAME_PREFIX_BYTES, length)));
  if (typeof header !== 'object' || header === null || typeof header.identifier !== 'string') {
    throw new Error('camera frame header is not an object with an identifier');
  }
  if (!(header.width > 0 && header.height > 0)) throw new Error('camera frame header has no valid width and height');
  return { header, payload: new Uint8Array(buffer, end) };
}

/**
 * Runs at most one asynchronous job at a time; a job submitted while one runs waits, replacing any
 * job already waiting (newest wins). Decoding a stale frame after a newer one arrived would only add
 * latency, and a queue of decodes would hitch the frame.
 * @template T
 */
export class LatestOnly {
  /** @param {(item: T) => Promise<void>} run */
  constructor(run) {
    this.run = run;
    this.busy = false;
    /** @type {T | null} */
    this.waiting = null;
    this.dropped = 0;
    this.completed = 0;
  }

  /** @param {T} item */
  submit(item) {
    if (this.busy) {
      if (this.waiting !== null) this.dropped++;
      this.waiting = item;
      return;
    }
    this.#start(item);
  }

  /** @param {T} item */
  async #start(item) {
    this.busy = true;
    try {
      await this.run(item);
    } catch (error) {
      console.warn('camera frame dropped:', error);
    } finally {
      this.completed++;
      this.busy = false;
      const next = this.waiting;
      this.waiting = null;
      if (next !== null) this.#start(next);
    }
  }
}
