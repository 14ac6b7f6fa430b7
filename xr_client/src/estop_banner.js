// @ts-check
/**
 * What the E-STOP banner says while an emergency stop is latched: which robots (or the whole fleet), who pressed
 * it, and what releases them. It stays until an operator resets the latch (the robots' statuses say when), unlike
 * a notice that fades. Pure: test/estop_banner.test.js.
 */
import { displayName } from './operator_names.js';

/** @typedef {{fleet: boolean, robots: string[], text: string, hint: string}} EstopBanner */

/**
 * @param {string[]} latched robots whose estop is latched (their statuses)
 * @param {string[]} robots every robot of the fleet
 * @param {Map<string, string | null>} by who latched each robot, as the `estop` messages said (may be unknown)
 * @param {string | null} me this client's id
 * @param {boolean} operator whether this client may reset it
 * @param {Map<string, string>} [names] connected clients' names (the relay's `operators`): the presser by name
 * @returns {EstopBanner | null}
 */
export function estopBanner(latched, robots, by, me, operator, names = new Map()) {
  if (latched.length === 0) return null;
  const fleet = robots.length > 0 && robots.every((r) => latched.includes(r));
  const pressers = new Set(latched.map((r) => by.get(r) ?? null));
  const presser = pressers.size === 1 ? [...pressers][0] : null;
  const who = presser ? ` · by ${displayName(presser, names, me ?? '')}` : '';
  const what = fleet ? 'ALL ROBOTS E-STOPPED' : `E-STOPPED: ${latched.join(', ')}`;
  const hint = operator
    ? 'stopped and held: nothing moves them until Reset E-STOP'
    : 'stopped and held until an operator resets it';
  return { fleet, robots: [...latched], text: `${what}${who}`, hint };
}
