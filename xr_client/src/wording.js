// @ts-check
/**
 * Counts in words the operator reads ("1 step", "3 steps"): a message that says "(1 steps)" reads as a bug, and
 * every count shown in the page or the headset goes through here; and the number a robot is called by. Pure:
 * test/wording.test.js.
 */

/**
 * @param {number} n @param {string} one the word for one ("step") @param {string} [many] for any other count
 *   (default: `one` + "s")
 */
export function count(n, one, many = `${one}s`) {
  return `${n} ${n === 1 ? one : many}`;
}

/** A finding's status as the report words it (relay/inspection/report_rows.py STATUS_WORDS): the list, the card. */
const STATUS_WORDS = Object.freeze({
  ok: 'OK',
  anomaly: 'Anomaly',
  needs_review: 'Needs review',
  changed: 'Changed since last round',
  false_alarm: 'False alarm',
});

/**
 * @param {string} status a finding's status code; one a newer relay adds reads as its code in words
 */
export function statusWords(status) {
  return STATUS_WORDS[/** @type {keyof typeof STATUS_WORDS} */ (status)] ?? status.replaceAll('_', ' ');
}

/** The number a robot's name ends in (robot17 -> 17), or null: what "robot 17" says and "17" searches for. */
export function nameNumber(/** @type {string} */ name) {
  const m = /(\d+)$/.exec(name);
  return m ? Number(m[1]) : null;
}
