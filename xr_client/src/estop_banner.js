// @ts-check
/**
 * What the E-STOP banner says while an emergency stop is latched: which robots (or the whole fleet), who pressed
 * it, and what releases them. It stays until an operator resets the latch (the robots' statuses say when), unlike
 * a notice that fades. It also words the question a reset asks first: whose E-STOP it lifts, on which robots
 * (issue #31: after an incident, nobody lifts someone else's stop without seeing that it is theirs). Pure:
 * test/estop_banner.test.js.
 */
import { displayName } from './operator_names.js';

/** @typedef {{fleet: boolean, robots: string[], text: string, hint: string, question: string}} EstopBanner */

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
  const question = resetQuestion(latched, fleet, (r) => {
    const id = by.get(r) ?? null;
    return id ? displayName(id, names, me ?? '') : 'someone the relay did not name';
  });
  return { fleet, robots: [...latched], text: `${what}${who}`, hint, question };
}

/**
 * "Reset the E-STOP pressed by Ana on all robots? ...", or each presser with their robots when several pressed.
 * @param {string[]} latched @param {boolean} fleet @param {(robot: string) => string} presserOf
 */
function resetQuestion(latched, fleet, presserOf) {
  /** @type {Map<string, string[]>} */
  const groups = new Map();
  for (const robot of latched) {
    const who = presserOf(robot);
    groups.set(who, [...(groups.get(who) ?? []), robot]);
  }
  const after = ' They can move again as soon as they are commanded.';
  if (groups.size === 1) {
    const [[who, stopped]] = groups;
    return `Reset the E-STOP pressed by ${who} on ${fleet ? 'all robots' : stopped.join(', ')}?${after}`;
  }
  const each = [...groups].map(([who, stopped]) => `by ${who} on ${stopped.join(', ')}`);
  return `Reset the E-STOPs pressed ${each.join('; ')}?${after}`;
}
