// @ts-check
/**
 * Smooth robot motion between pose updates: each new pose starts a glide from where the robot is drawn
 * now to the new pose, lasting one update interval (estimated from arrivals). So nothing jumps, and the
 * drawn robot is never more than one update behind. A pose far from the drawn one (a relocalisation or a
 * reconnect) is taken at once.
 */
import { normalizeAngle } from './frames.js';

export const SNAP_DISTANCE = 2.0;

export class PoseSmoother {
  constructor() {
    /** @type {{x: number, y: number, yaw: number} | null} */
    this.from = null;
    /** @type {{x: number, y: number, yaw: number} | null} */
    this.to = null;
    this.t0 = 0;
    /** Expected ms between updates; starts at 30 Hz, follows the measured arrivals. */
    this.interval = 33;
    /** @type {number | null} */
    this.lastArrival = null;
  }

  /**
   * A new pose (map frame) arrived at local time now (ms). @param {number} x @param {number} y @param {number} yaw
   * @param {number} now
   */
  push(x, y, yaw, now) {
    if (this.lastArrival !== null) {
      const gap = Math.min(500, Math.max(8, now - this.lastArrival));
      this.interval = this.interval * 0.8 + gap * 0.2;
    }
    this.lastArrival = now;
    const current = this.sample(now);
    if (!current || Math.hypot(current.x - x, current.y - y) > SNAP_DISTANCE) {
      this.from = { x, y, yaw };
    } else {
      this.from = current;
    }
    this.to = { x, y, yaw };
    this.t0 = now;
  }

  /** The pose to draw at local time now (ms), or null before the first pose. @param {number} now */
  sample(now) {
    if (!this.to || !this.from) return null;
    const a = Math.min(1, Math.max(0, (now - this.t0) / this.interval));
    return {
      x: this.from.x + (this.to.x - this.from.x) * a,
      y: this.from.y + (this.to.y - this.from.y) * a,
      yaw: this.from.yaw + normalizeAngle(this.to.yaw - this.from.yaw) * a,
    };
  }
}
