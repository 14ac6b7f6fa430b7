// @ts-check
/**
 * Laser scans (`<robot>/scan`: relay.messages.scan_message, docs/protocol.md) to points in the robot frame.
 * Two accepted shapes, both in the robot's base frame (REP 103, metres):
 * - what the relay sends, like sensor_msgs/LaserScan: `angle_min`, `angle_increment`, `ranges` (null, NaN or values
 *   outside [range_min, range_max] are no return), optional `range_min`, `range_max`;
 * - or `points`: a list of [x, y] pairs.
 */
import { MAX_SCAN_POINTS } from './protocol.js';

export { MAX_SCAN_POINTS }; // the relay thins a scan to this many ranges: the view's buffer holds them all

/**
 * @param {any} message
 * @param {Float32Array} out x, y pairs written here
 * @returns {number} how many points were written
 */
export function scanToPoints(message, out) {
  const capacity = Math.min(MAX_SCAN_POINTS, Math.floor(out.length / 2));
  let n = 0;
  if (Array.isArray(message.points)) {
    for (const p of message.points) {
      if (n >= capacity) break;
      if (Array.isArray(p) && Number.isFinite(p[0]) && Number.isFinite(p[1])) {
        out[2 * n] = p[0];
        out[2 * n + 1] = p[1];
        n++;
      }
    }
    return n;
  }
  const ranges = message.ranges;
  if (!Array.isArray(ranges) || !Number.isFinite(message.angle_min) || !Number.isFinite(message.angle_increment))
    return 0;
  const lo = Number.isFinite(message.range_min) ? message.range_min : 0;
  const hi = Number.isFinite(message.range_max) ? message.range_max : Infinity;
  for (let i = 0; i < ranges.length && n < capacity; i++) {
    const r = ranges[i];
    if (typeof r !== 'number' || !Number.isFinite(r) || r < lo || r > hi) continue;
    const a = message.angle_min + i * message.angle_increment;
    out[2 * n] = r * Math.cos(a);
    out[2 * n + 1] = r * Math.sin(a);
    n++;
  }
  return n;
}
