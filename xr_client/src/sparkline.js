// @ts-check
/**
 * A reading's trend as a sparkline: its last rounds' values scaled into a small box, with its threshold as a level
 * across it. Pure geometry (numbers in, SVG coordinates out); the desktop finding card draws it
 * (view/findings_panel.js) and the VR card (view/finding_card.js), and the report draws the same in Python
 * (relay/inspection/sparkline.py). The sensor panel's live sparkline is SensorHistory.sparkline's: a window of the
 * last minute sliding with the clock, where these are a finding's fixed rounds, spaced by their own times.
 */

/** The box a sparkline is drawn in, SVG user units: wide enough for ten rounds, as tall as two lines of text. */
export const SPARK_BOX = Object.freeze({ width: 160, height: 40, pad: 4 });

/**
 * @typedef {{x: number, y: number, value: number, t: number}} SparkPoint
 * @typedef {{points: SparkPoint[], limit: number | null, low: number, high: number}} Sparkline
 */

/**
 * The points of ``points`` ([time, value], oldest first) in ``box``: time left to right over the rounds' span (one
 * round: the middle), values bottom to top over their range widened to hold the threshold, so that its line is
 * always in view and a reading's distance to it reads true; ``limit`` is the threshold's y (null: none).
 * @param {number[][]} points
 * @param {number | null} threshold
 * @param {{width: number, height: number, pad: number}} [box]
 * @returns {Sparkline}
 */
export function sparkline(points, threshold, box = SPARK_BOX) {
  const values = points.map((p) => p[1]).filter(Number.isFinite);
  const all = threshold === null ? values : [...values, threshold];
  if (!all.length) return { points: [], limit: null, low: 0, high: 0 };
  let low = Math.min(...all);
  let high = Math.max(...all);
  // A flat series (or one reading at its threshold) gets a band around it: 5 % of its size, else 1.
  const margin = high > low ? (high - low) * 0.1 : Math.abs(high) * 0.05 || 1;
  low -= margin;
  high += margin;
  const first = points.length ? points[0][0] : 0;
  const span = points.length ? points[points.length - 1][0] - first : 0;
  const inner = { w: box.width - 2 * box.pad, h: box.height - 2 * box.pad };
  const y = (/** @type {number} */ v) => box.pad + ((high - v) / (high - low)) * inner.h;
  return {
    points: points
      .filter((p) => Number.isFinite(p[1]))
      .map(([t, value]) => ({
        x: box.pad + (span > 0 ? ((t - first) / span) * inner.w : inner.w / 2),
        y: y(value),
        value,
        t,
      })),
    limit: threshold === null ? null : y(threshold),
    low,
    high,
  };
}

/**
 * Where the threshold's label stands: above its line, or under it when the line runs in the upper half (a label
 * above would leave the box).
 * @param {number} limit the threshold's y
 * @param {{height: number}} [box]
 */
export function labelY(limit, box = SPARK_BOX) {
  return limit < box.height / 2 ? limit + 9 : limit - 2;
}

/**
 * An SVG ``points`` attribute of the line through them, to 0.1 unit.
 * @param {{x: number, y: number}[]} points
 */
export function polyline(points) {
  return points.map((p) => `${round(p.x)},${round(p.y)}`).join(' ');
}

/** @param {number} n */
function round(n) {
  return Math.round(n * 10) / 10;
}
