// @ts-check
/**
 * Counts in words the operator reads ("1 step", "3 steps"): a message that says "(1 steps)" reads as a bug, and
 * every count shown in the page or the headset goes through here. Pure: test/wording.test.js.
 */

/**
 * @param {number} n @param {string} one the word for one ("step") @param {string} [many] for any other count
 *   (default: `one` + "s")
 */
export function count(n, one, many = `${one}s`) {
  return `${n} ${n === 1 ? one : many}`;
}
