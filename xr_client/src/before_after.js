// @ts-check
/**
 * A change finding's before/after view on the desktop card: the baseline capture's image under the finding's, and
 * the labels of both. The wipe (0-100) is where the divide between them is: before on its left, after on its right,
 * as the labels under the slider read. Pure: the panel renders it.
 */

/** Where the wipe starts: half of each image. */
export const WIPE_START = 50;

/**
 * The wipe's position from an input's value: a whole number in 0-100 (a bad value: the start).
 * @param {string | number} value
 */
export function wipeAt(value) {
  const n = Number(value);
  return Number.isFinite(n) ? Math.round(Math.min(100, Math.max(0, n))) : WIPE_START;
}

/**
 * The CSS clip-path that shows the after image right of the divide at ``position`` percent of its width.
 * @param {number} position 0-100
 */
export function afterClip(position) {
  return `inset(0 0 0 ${wipeAt(position)}%)`;
}

/**
 * "before (time)" / "after (time)": the after image's time is the finding's; the before's, that of a finding about
 * the baseline capture when one is at hand (else only "before"). Shown to the minute, or to the second when both
 * fall in the same minute (rounds seconds apart would otherwise read as the same moment).
 * @param {{baseline: string | null, created: number}} finding
 * @param {Iterable<{capture: string, created: number}>} findings those the client holds
 * @param {(seconds: number) => string} [time] how a Unix time is shown (default: the page's local clock)
 * @returns {{before: string, after: string}}
 */
export function wipeLabels(finding, findings, time) {
  let before = null;
  for (const f of findings) {
    if (f.capture === finding.baseline && (before === null || f.created < before)) before = f.created;
  }
  const after = finding.created || null;
  const sameMinute = before !== null && after !== null && clockTime(before, 5) === clockTime(after, 5);
  const show = time ?? ((/** @type {number} */ s) => clockTime(s, sameMinute ? 8 : 5));
  return {
    before: before === null ? 'before' : `before (${show(before)})`,
    after: after === null ? 'after' : `after (${show(after)})`,
  };
}

/** @param {number} seconds @param {number} digits of the local time: 5 to the minute, 8 to the second */
function clockTime(seconds, digits) {
  const d = new Date(seconds * 1000);
  return `${d.toISOString().slice(0, 10)} ${d.toTimeString().slice(0, digits)}`;
}
