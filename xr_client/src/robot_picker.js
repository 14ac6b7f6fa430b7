// @ts-check
/**
 * What the desktop's robot picker lists, without DOM (view/robot_picker.js draws it): every robot's facts in words
 * (its status, battery, mission, open alerts), the robots a search finds, best match first, in natural order
 * (robot2 before robot10) or by status (what needs the operator first). Pure: test/robot_picker.test.js.
 */
import { count, nameNumber } from './wording.js';

/**
 * What the picker knows of a robot; null where the relay has not told it (no status yet, no battery sensor).
 * @typedef {{name: string, online: boolean | null, mode: string | null, estopped: boolean, battery: number | null,
 *   mission: string, alerts: number}} RobotFacts
 */
/** @typedef {'name' | 'status'} PickerSort */
/** @typedef {{name: string, status: string, rank: number, details: string}} PickerRow */

/** Names in natural order: digits compared as numbers ("robot2" < "robot10"), letters without case. */
const NATURAL = new Intl.Collator('en', { numeric: true, sensitivity: 'base' });

/** @param {string} a @param {string} b @returns {number} */
export function naturalCompare(a, b) {
  return NATURAL.compare(a, b) || (a < b ? -1 : a > b ? 1 : 0);
}

/**
 * A robot's state in a word, and its place when sorted by status: an E-STOP first (it waits for a reset), then
 * what cannot be reached, what moves, what waits, and a robot that has sent no status yet.
 * @param {RobotFacts} robot @returns {{status: string, rank: number}}
 */
export function statusOf(robot) {
  if (robot.estopped) return { status: robot.online === false ? 'E-STOPPED · offline' : 'E-STOPPED', rank: 0 };
  if (robot.online === false) return { status: 'offline', rank: 1 };
  if (robot.mode === null) return { status: 'no status yet', rank: 4 };
  return { status: robot.mode, rank: robot.mode === 'idle' ? 3 : 2 };
}

/** The line under a robot's name: "battery 81 % · mission: step 2 of 3 (...) · 1 alert". @param {RobotFacts} r */
export function detailsOf(r) {
  const parts = [
    r.battery === null ? '' : `battery ${Math.round(r.battery)} %`,
    r.mission,
    r.alerts > 0 ? count(r.alerts, 'alert') : '',
  ];
  return parts.filter(Boolean).join(' · ');
}

/** Lower case, without spaces, dashes and underscores: "Robot 17" finds robot17. @param {string} text */
function folded(text) {
  return text.toLowerCase().replace(/[\s_-]+/g, '');
}

/**
 * How well a name matches the search (lower is better), or null for no match: the name itself, or the number it
 * ends with ("17": robot17), then a name that starts with it, then one that holds it (robot117).
 * @param {string} name @param {string} query
 */
export function matchOf(name, query) {
  const q = folded(query);
  if (!q) return 0;
  const n = folded(name);
  if (n === q || (/^\d+$/.test(q) && nameNumber(n) === Number(q))) return 0;
  if (n.startsWith(q)) return 1;
  return n.includes(q) ? 2 : null;
}

/**
 * The picker's list: the robots the search finds, best match first, then in the order asked.
 * @param {RobotFacts[]} robots @param {string} query @param {PickerSort} sort @returns {PickerRow[]}
 */
export function pickerRows(robots, query, sort) {
  const rows = [];
  for (const robot of robots) {
    const match = matchOf(robot.name, query);
    if (match === null) continue;
    rows.push({ match, row: { name: robot.name, ...statusOf(robot), details: detailsOf(robot) } });
  }
  rows.sort(
    (a, b) =>
      a.match - b.match || (sort === 'status' ? a.row.rank - b.row.rank : 0) || naturalCompare(a.row.name, b.row.name),
  );
  return rows.map((r) => r.row);
}

/**
 * The fleet's facts: each robot's from the fleet model's entry (its status; a sensor named for the battery, in
 * percent), its mission's progress ('' on none) and how many of the open alerts are its own.
 * @param {Iterable<import('./fleet_model.js').RobotEntry>} entries @param {(robot: string) => string} progress
 * @param {{robot: string | null}[]} alerts @returns {RobotFacts[]}
 */
export function fleetFacts(entries, progress, alerts) {
  /** @type {Map<string, number>} */
  const open = new Map();
  for (const { robot } of alerts) if (robot !== null) open.set(robot, (open.get(robot) ?? 0) + 1);
  return [...entries].map((e) => factsOf(e, progress(e.description.name), open.get(e.description.name) ?? 0));
}

/**
 * @param {import('./fleet_model.js').RobotEntry} entry @param {string} mission @param {number} alerts
 * @returns {RobotFacts}
 */
function factsOf(entry, mission, alerts) {
  const status = entry.status;
  const battery = [...entry.sensors.values()].find((s) => /battery/i.test(s.name) && s.unit === '%');
  return {
    name: entry.description.name,
    online: status ? status.online : null,
    mode: status ? status.mode : null,
    estopped: status?.estopped ?? false,
    battery: battery ? battery.value : null,
    mission,
    alerts,
  };
}
