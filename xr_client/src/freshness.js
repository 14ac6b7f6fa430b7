// @ts-check
/**
 * How old what the page shows is, against how often it usually comes: a robot's pose or a sensor's reading is
 * stale when it has not come for several of its usual intervals (learned from its own arrivals, so a 30 Hz odom
 * and a 1 Hz gas sensor are each judged by their own rate), and everything is stale when the relay itself has
 * said nothing for longer than its pings allow. Stale things are drawn grey with their age, never as live.
 * Pure (times are the page's ms, passed in): test/freshness.test.js.
 */

/** Nothing is stale sooner than this, ms (a 30 Hz pose skipping a few frames is not news). */
export const MIN_STALE_MS = 1000;
/** Stale after this many usual intervals without news. */
export const STALE_INTERVALS = 3;
/** The relay answers a ping every 2 s (reconnect.js PING_PERIOD_MS): silence past this means the link is stale. */
export const LINK_STALE_MS = 3000;
/** Intervals remembered per key, for its usual one (the median). */
const SAMPLES = 15;

export class Freshness {
  /** @type {Map<string, {last: number, intervals: number[]}>} */
  #keys = new Map();

  /** Something arrived for `key` at `now`. @param {string} key @param {number} now */
  seen(key, now) {
    const entry = this.#keys.get(key);
    if (!entry) {
      this.#keys.set(key, { last: now, intervals: [] });
      return;
    }
    const interval = now - entry.last;
    entry.last = now;
    if (interval <= 0) return;
    entry.intervals.push(interval);
    if (entry.intervals.length > SAMPLES) entry.intervals.shift();
  }

  /** ms since `key` last arrived, or null when it never did. @param {string} key @param {number} now */
  age(key, now) {
    const entry = this.#keys.get(key);
    return entry ? now - entry.last : null;
  }

  /** The usual interval of `key` (the median of the last ones), ms, or null before two arrivals. @param {string} key */
  usual(key) {
    const intervals = this.#keys.get(key)?.intervals ?? [];
    if (intervals.length === 0) return null;
    const sorted = [...intervals].sort((a, b) => a - b);
    return sorted[Math.floor(sorted.length / 2)];
  }

  /** How long `key` may be silent before it is stale, ms. @param {string} key */
  limit(key) {
    return Math.max(MIN_STALE_MS, STALE_INTERVALS * (this.usual(key) ?? 0));
  }

  /**
   * Whether `key` has been silent past its limit (never seen is not stale: it is unknown). @param {string} key
   * @param {number} now
   */
  stale(key, now) {
    const age = this.age(key, now);
    return age !== null && age > this.limit(key);
  }

  /** A new relay: what came from the old one says nothing about the new one's rates. */
  reset() {
    this.#keys.clear();
  }
}

/**
 * A duration for an operator, in whole units (labels redraw only when it changes): "1 s", "12 s", "3 min".
 * @param {number} ms
 */
export function formatSilence(ms) {
  const s = Math.floor(ms / 1000);
  if (s < 120) return `${Math.max(1, s)} s`;
  return `${Math.floor(s / 60)} min`;
}
