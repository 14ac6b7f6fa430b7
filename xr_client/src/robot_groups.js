// @ts-check
/**
 * Groups of robots an operator stops or sends targets to together: each team of robots.yaml (hello's `team`), then
 * each room of the scene (hello's `rooms`) with the robots standing in it now. A robot is in one team at most and in
 * the room its pose is in (a pose on a shared wall: the first room listed); one with no pose yet is in no room.
 * Pure: test/robot_groups.test.js.
 */
import { naturalCompare } from './robot_picker.js';

/** @typedef {{id: string, kind: 'team' | 'room', label: string, robots: string[]}} RobotGroup */

/**
 * @param {Iterable<{name: string, team?: string | null, pose: {x: number, y: number} | null}>} robots
 * @param {{name: string, title: string, bounds: number[]}[]} rooms each `bounds`: [x0, y0, x1, y1] in the map frame
 * @returns {RobotGroup[]} teams by name, then rooms in the scene's order; none empty; robots in natural order
 */
export function robotGroups(robots, rooms) {
  /** @type {Map<string, string[]>} */
  const teams = new Map();
  /** @type {Map<string, string[]>} */
  const inRoom = new Map();
  for (const robot of robots) {
    if (robot.team) teams.set(robot.team, [...(teams.get(robot.team) ?? []), robot.name]);
    const pose = robot.pose;
    const room = pose ? rooms.find((r) => inside(r.bounds, pose)) : undefined;
    if (room) inRoom.set(room.name, [...(inRoom.get(room.name) ?? []), robot.name]);
  }
  const sorted = (/** @type {string[]} */ names) => [...names].sort(naturalCompare);
  return [
    ...[...teams.keys()].sort(naturalCompare).map((team) => ({
      id: `team:${team}`,
      kind: /** @type {const} */ ('team'),
      label: team,
      robots: sorted(teams.get(team) ?? []),
    })),
    ...rooms
      .filter((room) => inRoom.has(room.name))
      .map((room) => ({
        id: `room:${room.name}`,
        kind: /** @type {const} */ ('room'),
        label: room.title || room.name,
        robots: sorted(inRoom.get(room.name) ?? []),
      })),
  ];
}

/** @param {number[]} bounds [x0, y0, x1, y1] @param {{x: number, y: number}} p */
function inside(bounds, p) {
  const [x0, y0, x1, y1] = bounds;
  return p.x >= Math.min(x0, x1) && p.x <= Math.max(x0, x1) && p.y >= Math.min(y0, y1) && p.y <= Math.max(y0, y1);
}

/** How a group is named on a button: "North crew (3)", "Corridor (2)". @param {RobotGroup} group */
export function groupTitle(group) {
  return `${group.label} (${group.robots.length})`;
}
