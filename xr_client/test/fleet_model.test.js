// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { FleetModel } from '../src/fleet_model.js';

const hello = {
  identifier: 'hello',
  client_id: 'c1',
  bounds: [0, 0, 18, 10],
  robots: [{ name: 'robot1', colour: '#e6194b', limits: { linear: 0.6, angular: 1.8 }, sensors: [], cameras: [] }],
  state: {
    robot1: {
      pose: { identifier: 'robot1/pose', x: 3, y: 1.5, yaw: 1.57, stamp: 1 },
      sensors: { gas: { identifier: 'robot1/sensor', name: 'gas', value: 5, unit: 'ppm', warning: false } },
      status: { identifier: 'robot1/status', online: true, age: 0.01, mode: 'idle', goal: null, controller: null },
    },
  },
};

test('hello restores the whole fleet state', () => {
  const model = new FleetModel();
  assert.equal(model.apply(hello), true);
  const robot = model.robots.get('robot1');
  assert.ok(robot);
  assert.deepEqual(robot.pose, { x: 3, y: 1.5, yaw: 1.57, stamp: 1 });
  assert.equal(robot.sensors.get('gas')?.value, 5);
  assert.equal(robot.status?.mode, 'idle');
});

test('updates for unknown robots and kinds are ignored', () => {
  const model = new FleetModel();
  model.apply(hello);
  assert.equal(model.apply({ identifier: 'robot9/pose', x: 1, y: 1, yaw: 0, stamp: 2 }), false);
  assert.equal(model.apply({ identifier: 'robot1/unknown' }), false);
  assert.equal(model.apply({ identifier: 'robot1/pose', x: 4, y: 2, yaw: 0, stamp: 2 }), true);
  assert.equal(model.robots.get('robot1')?.pose?.x, 4);
});
