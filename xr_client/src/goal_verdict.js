// @ts-check
/**
 * What a press (or a trigger) would do where the goal pointer meets the twin, decided before the operator lets
 * go, so the cursor and the arc can say it: send a goal there, select the robot under it, or nothing, with the
 * reason (a wall, outside the map, too close to another robot). The relay checks the same rules when a goal
 * arrives (relay/safety.py's GOAL_CLEARANCE, generated into protocol.js); this is what the operator sees first.
 * Pure: test/goal_verdict.test.js.
 */
import { GOAL_CLEARANCE } from './protocol.js';

/** A point this close to a robot (metres, map frame) is a point on that robot: it selects it. */
export const SELECT_RADIUS = 0.4;

/**
 * @typedef {{kind: 'goal'} | {kind: 'select', robot: string} | {kind: 'refused', reason: string}
 *   | {kind: 'none', reason: string} | {kind: 'takeover', holder: string}} GoalVerdict `takeover`: a good goal
 *   for a robot another operator (or a mission) holds: the click offers to take it over and send it there
 * @typedef {{point: {x: number, y: number}, floor: boolean} | null} PointerHit where the pointer meets the twin
 *   (map frame) and whether it is floor, or null when it meets nothing
 * @typedef {{name: string, x: number, y: number}} RobotSpot
 */

/**
 * @param {PointerHit} hit
 * @param {{robots: RobotSpot[], selected: string | null, bounds: number[] | null, holder?: string | null}} context
 *   robots with a pose, the robot the goal would be for, the map's bounds (min x, min y, max x, max y) when known,
 *   who holds that robot when it is not this operator
 * @returns {GoalVerdict}
 */
export function goalVerdict(hit, context) {
  if (!hit) return { kind: 'none', reason: 'point at the floor' };
  const { x, y } = hit.point;
  let nearest = null;
  let nearestDistance = Infinity;
  for (const robot of context.robots) {
    const d = Math.hypot(robot.x - x, robot.y - y);
    if (d < nearestDistance) [nearest, nearestDistance] = [robot, d];
  }
  if (nearest && nearestDistance <= SELECT_RADIUS) return { kind: 'select', robot: nearest.name };
  if (!hit.floor) return { kind: 'refused', reason: 'a wall or an obstacle: point at the floor' };
  const b = context.bounds;
  if (b && (x < b[0] || y < b[1] || x > b[2] || y > b[3])) return { kind: 'refused', reason: 'outside the map' };
  for (const robot of context.robots) {
    const d = Math.hypot(robot.x - x, robot.y - y);
    if (robot.name !== context.selected && d < GOAL_CLEARANCE) {
      return {
        kind: 'refused',
        reason: `too close to ${robot.name} (${d.toFixed(1)} m; goals keep ${GOAL_CLEARANCE} m from other robots)`,
      };
    }
  }
  return context.holder ? { kind: 'takeover', holder: context.holder } : { kind: 'goal' };
}

/**
 * The robots with a pose, where they stand. @param {import('./fleet_model.js').FleetModel} fleet @returns {RobotSpot[]}
 */
export function robotSpots(fleet) {
  return [...fleet.robots.values()]
    .filter((r) => r.pose)
    .map((r) => ({
      name: r.description.name,
      x: /** @type {{x: number}} */ (r.pose).x,
      y: /** @type {{y: number}} */ (r.pose).y,
    }));
}

/** A verdict in a few words, for the pointer's label (null: nothing to say). @param {GoalVerdict | null} verdict */
export function verdictText(verdict) {
  if (!verdict || verdict.kind === 'goal') return null;
  if (verdict.kind === 'select') return `select ${verdict.robot}`;
  if (verdict.kind === 'takeover') return `held by ${verdict.holder}: click to take over and send it here`;
  return verdict.kind === 'refused' ? `can't go there: ${verdict.reason}` : null;
}

/**
 * The pointer's colour for a verdict: blue a goal, white a selection, red a refusal, grey nothing.
 * @param {GoalVerdict | null} verdict
 */
export function verdictColour(verdict) {
  switch (verdict?.kind) {
    case 'goal':
      return '#3d8bff';
    case 'select':
      return '#ffffff';
    case 'refused':
      return '#e02424';
    case 'takeover':
      return '#ffb020';
    default:
      return '#8a93a3';
  }
}
