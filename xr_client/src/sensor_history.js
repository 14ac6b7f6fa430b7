// @ts-check
/**
 * The last minute of each sensor of each robot, for the sparklines, and the warning crossings that raise
 * a haptic pulse and a banner: a reading whose `warning` turns true after being false (or first seen).
 */

export const HISTORY_MS = 60000;

export class SensorHistory {
  /** @param {number} [window] ms kept */
  constructor(window = HISTORY_MS) {
    this.window = window;
    /** @type {Map<string, {t: number[], v: number[]}>} */
    this.series = new Map();
    /** @type {Map<string, boolean>} */
    this.warning = new Map();
  }

  /**
   * Record a reading at local time `now` (ms). Returns true when this reading crossed into warning.
   * @param {string} robot @param {string} sensor @param {number} value @param {boolean} warning @param {number} now
   */
  add(robot, sensor, value, warning, now) {
    const key = `${robot}/${sensor}`;
    let s = this.series.get(key);
    if (!s) {
      s = { t: [], v: [] };
      this.series.set(key, s);
    }
    s.t.push(now);
    s.v.push(value);
    let drop = 0;
    while (drop < s.t.length && now - s.t[drop] > this.window) drop++;
    if (drop) {
      s.t.splice(0, drop);
      s.v.splice(0, drop);
    }
    const before = this.warning.get(key) ?? false;
    this.warning.set(key, warning);
    return warning && !before;
  }

  /** @param {string} robot @param {string} sensor */
  values(robot, sensor) {
    return this.series.get(`${robot}/${sensor}`) ?? { t: [], v: [] };
  }

  /**
   * The sparkline of the last minute as points in a width x height box (y down), with the range shown. The range
   * takes in the sensor's warning thresholds, so that noise far below a threshold draws flat, and the threshold
   * has a height to be drawn at (`lines`); without thresholds it is never narrower than 10 % of the level, so
   * ±2 ppm of noise on a quiet sensor does not fill the box like an alarm.
   * @param {string} robot @param {string} sensor @param {number} now @param {number} width @param {number} height
   * @param {{above?: number | null, below?: number | null}} [thresholds]
   */
  sparkline(robot, sensor, now, width, height, thresholds = {}) {
    const { t, v } = this.values(robot, sensor);
    if (v.length === 0)
      return {
        points: /** @type {[number, number][]} */ ([]),
        min: 0,
        max: 0,
        breaks: /** @type {number[]} */ ([]),
        lines: /** @type {number[]} */ ([]),
      };
    let min = Infinity;
    let max = -Infinity;
    for (const x of v) {
      if (x < min) min = x;
      if (x > max) max = x;
    }
    const marks = [thresholds.above, thresholds.below].filter((x) => typeof x === 'number' && Number.isFinite(x));
    for (const x of /** @type {number[]} */ (marks)) {
      min = Math.min(min, x);
      max = Math.max(max, x);
    }
    const least = 0.1 * Math.max(Math.abs(max), Math.abs(min), 1e-6);
    if (max - min < least) {
      const middle = (max + min) / 2;
      [min, max] = [middle - least / 2, middle + least / 2];
    }
    if (marks.length) max += 0.1 * (max - min); // the threshold line below the top edge
    const span = max - min || 1;
    const lines = /** @type {number[]} */ (marks).map((x) => height * (1 - (x - min) / span));
    /** @type {[number, number][]} */
    const points = v.map((value, i) => [
      width * (1 - Math.min(1, Math.max(0, (now - t[i]) / this.window))),
      height * (1 - (value - min) / span),
    ]);
    return { points, min, max, breaks: gaps(t), lines };
  }

  /**
   * The indices of a sensor's readings that come after a gap (gaps(): no line is drawn across them).
   * @param {string} robot @param {string} sensor
   */
  breaks(robot, sensor) {
    return gaps(this.values(robot, sensor).t);
  }

  /** Whether any sensor of the robot is in warning now. @param {string} robot */
  robotWarning(robot) {
    for (const [key, on] of this.warning) if (on && key.startsWith(`${robot}/`)) return true;
    return false;
  }

  clear() {
    this.series.clear();
    this.warning.clear();
  }
}

/** A pause between readings longer than this many usual intervals (and GAP_MIN_MS) is a gap in the data. */
const GAP_INTERVALS = 4;
export const GAP_MIN_MS = 2000;

/**
 * The indices that follow a gap: a pause longer than GAP_INTERVALS times the usual (median) interval and GAP_MIN_MS.
 * @param {number[]} t reading times, ms, ascending
 */
export function gaps(t) {
  if (t.length < 3) return [];
  const intervals = t.slice(1).map((x, i) => x - t[i]);
  const usual = [...intervals].sort((a, b) => a - b)[Math.floor(intervals.length / 2)];
  const limit = Math.max(GAP_MIN_MS, GAP_INTERVALS * usual);
  /** @type {number[]} */
  const out = [];
  intervals.forEach((d, i) => {
    if (d > limit) out.push(i + 1);
  });
  return out;
}
