// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { valvePlacement } from '../src/valve.js';
import { MessageRouter } from '../src/message_router.js';
import { FleetModel } from '../src/fleet_model.js';
import { GoalTracker } from '../src/goal_pointer.js';
import { SensorHistory } from '../src/sensor_history.js';
import { CommandSender } from '../src/command_sender.js';

const HELLO = JSON.parse(readFileSync(new URL('./fixtures/hello.json', import.meta.url), 'utf8'));

/** docs/protocol.md's example: robots.yaml's valve, an eighth of a turn, held. @type {import('../src/protocol.js').ValveMessage} */
const VALVE = {
  identifier: 'valve',
  x: 15.6,
  y: 7.25,
  z: 0.2,
  yaw: -1.5708,
  radius: 0.05,
  angle: 0.785,
  held: true,
  shut: false,
};

test('the wheel sits at its centre in the scene, its local +x along its axis, turned as reported', () => {
  const identity = { x: 0, y: 0, z: 0, yaw: 0 };
  const { position, heading, angle } = valvePlacement(identity, VALVE);
  assert.deepEqual(position, [15.6, 0.2, -7.25]); // glTF: (x, z, -y)
  assert.equal(heading, -1.5708);
  // Its axis looks south (map -y): glTF +z. three.js turns local +x by `heading` about +y to (cos, 0, -sin).
  assert.ok(Math.abs(Math.cos(heading)) < 1e-4 && Math.abs(-Math.sin(heading) - 1) < 1e-4);
  assert.equal(angle, 0.785);
  // A twin placed elsewhere carries the wheel with it.
  const moved = valvePlacement({ x: 1, y: 2, z: 0.5, yaw: Math.PI / 2 }, VALVE);
  assert.ok(Math.abs(moved.position[0] - (1 - 7.25)) < 1e-9 && Math.abs(moved.position[2] + (2 + 15.6)) < 1e-9);
  assert.ok(Math.abs(moved.position[1] - 0.7) < 1e-9);
  assert.ok(Math.abs(moved.heading - (-1.5708 + Math.PI / 2)) < 1e-12);
});

test('the router keeps the newest valve until the next hello, which the relay follows with it again', () => {
  const commands = new CommandSender({ send: () => 'r1' }, () => {});
  const router = new MessageRouter({
    fleet: new FleetModel(),
    goals: new GoalTracker(),
    history: new SensorHistory(),
    commands,
  });
  router.route(HELLO, 0);
  assert.equal(router.arms.valve, null);
  assert.deepEqual(router.route(VALVE, 1), []);
  assert.equal(router.arms.valve, VALVE);
  const shut = { ...VALVE, angle: 1.6, held: false, shut: true };
  router.route(shut, 2);
  assert.equal(router.arms.valve, shut);
  router.route(HELLO, 3);
  assert.equal(router.arms.valve, null);
});
