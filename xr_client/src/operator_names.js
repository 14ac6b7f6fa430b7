// @ts-check
/**
 * Operators by name, not by connection id: what the relay's `operators` roster says each client is called, how a
 * holder reads in labels and menus ("you", "Ana", "a mission"), and what a name may be (the relay's rule, checked
 * before sending). Pure: test/operator_names.test.js.
 */

/** The relay's limit on a name's length (relay/protocol.py MAX_NAME_LENGTH). */
export const MAX_NAME_LENGTH = 40;
/** Where the page remembers the operator's name. */
export const NAME_KEY = 'xr-relay-operator-name';

/**
 * How a holder of a robot (a client id, a mission's `mission:<id>`, or null) reads for this operator.
 * @param {string | null | undefined} holder @param {Map<string, string>} names @param {string} me this client's id
 */
export function displayName(holder, names, me) {
  if (!holder) return '';
  if (holder === me) return 'you';
  if (holder.startsWith('mission:')) return 'a mission';
  return names.get(holder) ?? holder;
}

/**
 * A name as the relay will take it (trimmed, inner spaces collapsed), or null when it cannot be one.
 * @param {string} text
 */
export function cleanName(text) {
  const name = text.trim().replace(/\s+/g, ' ');
  if (!name || name.length > MAX_NAME_LENGTH) return null;
  // Letters of any script, digits, spaces and . _ - ' : what a person's name or a call sign needs, nothing that
  // could pass for markup or a control character in another operator's label.
  return /^[\p{L}\p{N}_][\p{L}\p{N} ._'-]*$/u.test(name) ? name : null;
}
