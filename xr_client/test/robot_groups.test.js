// Groups of robots: each team, then each room with robots standing in it now.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { groupTitle, robotGroups } from '../src/robot_groups.js';

const rooms = [
  { name: 'corridor', title: 'Corridor', bounds: [0, 0, 18, 3] },
  { name: 'chemical_storage', title: 'Chemical storage', bounds: [0, 3, 6, 10] },
  { name: 'plumbing', title: 'Plumbing', bounds: [12, 3, 18, 10] },
];

test('teams by name, then rooms in the scene order with the robots in them, each in natural order', () => {
  const groups = robotGroups(
    [
      { name: 'robot10', team: 'North crew', pose: { x: 2, y: 5 } },
      { name: 'robot2', team: 'North crew', pose: { x: 9, y: 1.5 } },
      { name: 'robot3', team: 'B shift', pose: { x: 15, y: 1.5 } },
      { name: 'robot4', team: null, pose: null }, // no pose yet: in no room
      { name: 'robot5', pose: { x: 6, y: 3 } }, // on the corridor's wall with chemical storage: the first listed
    ],
    rooms,
  );
  assert.deepEqual(
    groups.map((g) => [g.id, g.kind, g.label, g.robots]),
    [
      ['team:B shift', 'team', 'B shift', ['robot3']],
      ['team:North crew', 'team', 'North crew', ['robot2', 'robot10']],
      ['room:corridor', 'room', 'Corridor', ['robot2', 'robot3', 'robot5']],
      ['room:chemical_storage', 'room', 'Chemical storage', ['robot10']],
    ],
  );
  assert.equal(groupTitle(groups[1]), 'North crew (2)');
  assert.deepEqual(robotGroups([{ name: 'a', pose: { x: 50, y: 50 } }], rooms), [], 'outside every room, no team');
});
