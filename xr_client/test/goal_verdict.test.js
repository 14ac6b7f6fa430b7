// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { goalVerdict, SELECT_RADIUS, verdictColour } from '../src/goal_verdict.js';
import { GOAL_CLEARANCE } from '../src/protocol.js';

const ROBOTS = [
  { name: 'robot1', x: 3, y: 1.5 },
  { name: 'robot2', x: 9, y: 1.5 },
];
const CONTEXT = { robots: ROBOTS, selected: 'robot1', bounds: [0, 0, 18, 10] };
/** @param {number} x @param {number} y @param {boolean} [floor] */
const at = (x, y, floor = true) => ({ point: { x, y }, floor });

test('a point on a robot selects it, whichever robot and whatever is under it', () => {
  assert.deepEqual(goalVerdict(at(9.1, 1.6), CONTEXT), { kind: 'select', robot: 'robot2' });
  assert.deepEqual(goalVerdict(at(3, 1.5 + SELECT_RADIUS * 0.9, false), CONTEXT), { kind: 'select', robot: 'robot1' });
});

test('a goal next to another robot is refused with the distance and the rule; the robot itself does not count', () => {
  const verdict = goalVerdict(at(9, 1.5 + (SELECT_RADIUS + GOAL_CLEARANCE) / 2), CONTEXT);
  assert.equal(verdict.kind, 'refused');
  assert.match(
    /** @type {{reason: string}} */ (verdict).reason,
    /^too close to robot2 \(0\.5 m; goals keep 0\.6 m from other robots\)$/,
  );
  assert.deepEqual(goalVerdict(at(3, 2.1), CONTEXT), { kind: 'goal' }, 'near the selected robot itself is a goal');
  assert.deepEqual(goalVerdict(at(9, 1.5 + GOAL_CLEARANCE + 0.01), CONTEXT), { kind: 'goal' });
});

test('walls, the world outside the map and nothing at all are said, not silently ignored', () => {
  assert.deepEqual(goalVerdict(at(6, 3, false), CONTEXT), {
    kind: 'refused',
    reason: 'a wall or an obstacle: point at the floor',
  });
  assert.deepEqual(goalVerdict(at(20, 5), CONTEXT), { kind: 'refused', reason: 'outside the map' });
  assert.deepEqual(goalVerdict(null, CONTEXT), { kind: 'none', reason: 'point at the floor' });
  assert.deepEqual(goalVerdict(at(20, 5), { ...CONTEXT, bounds: null }), { kind: 'goal' }, 'no map: the relay decides');
  const colours = new Set(
    ['goal', 'select', 'refused', 'none'].map((kind) => verdictColour(/** @type {any} */ ({ kind }))),
  );
  assert.equal(colours.size, 4, 'each outcome has its own colour');
});
